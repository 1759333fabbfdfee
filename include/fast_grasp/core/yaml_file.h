// Loading a configuration YAML file. ROS-free.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

namespace fast_grasp
{
/// YAML::LoadFile for regular files only. yaml-cpp 0.7 leaks its 2 KB read buffer when the path
/// is a directory (found by fuzzing robot configs whose home_pose named a folder, session 15);
/// anything but a regular file throws YAML::BadFile, as a missing file does.
YAML::Node loadYamlFile(const std::string& path);

}  // namespace fast_grasp
