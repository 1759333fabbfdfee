#include "fast_grasp/arm/robot_config.h"

#include "fast_grasp/core/yaml_file.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace fast_grasp
{
namespace
{
namespace fs = std::filesystem;

Eigen::VectorXd readVector(const YAML::Node& root, const std::string& key, const std::string& file)
{
  if (!root[key])
    return Eigen::VectorXd();
  if (!root[key].IsSequence())
    throw std::runtime_error("robot config '" + file + "': '" + key + "' must be a list");
  Eigen::VectorXd v(static_cast<Eigen::Index>(root[key].size()));
  for (std::size_t i = 0; i < root[key].size(); ++i)
    v[static_cast<Eigen::Index>(i)] = root[key][i].as<double>();
  return v;
}

std::string resolve(const std::string& path, const fs::path& folder)
{
  if (path.empty() || fs::path(path).is_absolute())
    return path;
  return (folder / path).lexically_normal().string();
}
}  // namespace

Eigen::VectorXd RobotConfig::homePose(const std::vector<std::string>& joint_names) const
{
  Eigen::VectorXd q(static_cast<Eigen::Index>(joint_names.size()));
  for (std::size_t j = 0; j < joint_names.size(); ++j)
  {
    const auto it = home_pose_rad.find(joint_names[j]);
    if (it == home_pose_rad.end())
      throw std::runtime_error("robot '" + name + "': home pose lacks joint '" + joint_names[j] + "'");
    q[static_cast<Eigen::Index>(j)] = it->second;
  }
  return q;
}

std::string robotConfigPath(const std::string& config_dir, const std::string& name)
{
  return (fs::path(config_dir) / "robots" / (name + ".yaml")).string();
}

RobotConfig loadRobotConfig(const std::string& yaml_path)
{
  YAML::Node root;
  try
  {
    root = loadYamlFile(yaml_path);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error("robot config '" + yaml_path + "': " + e.what());
  }
  const fs::path folder = fs::path(yaml_path).parent_path();
  RobotConfig robot;
  robot.name = fs::path(yaml_path).stem().string();
  try
  {
    if (!root["urdf"])
      throw std::runtime_error("robot config '" + yaml_path + "': needs 'urdf'");
    robot.urdf_path = resolve(root["urdf"].as<std::string>(), folder);
    if (root["base_link"])
      robot.base_link = root["base_link"].as<std::string>();
    if (root["tip_link"])
      robot.tip_link = root["tip_link"].as<std::string>();
    if (root["camera_link"])
      robot.camera_link = root["camera_link"].as<std::string>();
    if (root["joints"])
      robot.joints = root["joints"].as<std::vector<std::string>>();
    const Eigen::VectorXd limit = readVector(root, "joint_limits_rad", yaml_path);
    if (limit.size() > 0)
    {
      robot.joint_lower_rad = -limit;
      robot.joint_upper_rad = limit;
    }
    const Eigen::VectorXd lower = readVector(root, "joint_lower_rad", yaml_path);
    const Eigen::VectorXd upper = readVector(root, "joint_upper_rad", yaml_path);
    if (lower.size() > 0)
      robot.joint_lower_rad = lower;
    if (upper.size() > 0)
      robot.joint_upper_rad = upper;
    robot.velocity_limit_rad_s = readVector(root, "velocity_limit_rad_s", yaml_path);
    robot.acceleration_limit_rad_s2 = readVector(root, "acceleration_limit_rad_s2", yaml_path);
    if (root["link_padding_m"])
      robot.link_padding_m = root["link_padding_m"].as<double>();
    if (root["object_contact_links"])
      robot.object_contact_links = root["object_contact_links"].as<std::vector<std::string>>();
    if (root["contact_link_padding_m"])
      robot.contact_link_padding_m = root["contact_link_padding_m"].as<double>();
    const Eigen::VectorXd base = readVector(root, "benchmark_base_m", yaml_path);
    if (base.size() == 3)
      robot.benchmark_base_m = base;
    else if (base.size() != 0)
      throw std::runtime_error("robot config '" + yaml_path + "': 'benchmark_base_m' needs 3 entries (x, y, z)");
    if (root["planner_parameters"])
    {
      if (!root["planner_parameters"].IsMap())
        throw std::runtime_error("robot config '" + yaml_path + "': 'planner_parameters' must map planner names");
      for (const auto& planner : root["planner_parameters"])
      {
        auto& entry = robot.planner_parameters[planner.first.as<std::string>()];
        if (!planner.second.IsMap())
          throw std::runtime_error("robot config '" + yaml_path + "': 'planner_parameters." +
                                   planner.first.as<std::string>() + "' must map parameter names");
        for (const auto& kv : planner.second)
          entry[kv.first.as<std::string>()] = kv.second.as<std::string>();
      }
    }
    if (root["home_pose"])
    {
      robot.home_pose_path = resolve(root["home_pose"].as<std::string>(), folder);
      const YAML::Node home = loadYamlFile(robot.home_pose_path);
      for (const auto& entry : home)
        robot.home_pose_rad[entry.first.as<std::string>()] = entry.second.as<double>();
    }
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("robot config '" + yaml_path + "': bad value: " + e.what());
  }
  const std::size_t n = robot.joints.size();
  auto sized = [&](const Eigen::VectorXd& v, const char* key) {
    if (v.size() > 0 && n > 0 && static_cast<std::size_t>(v.size()) != n)
      throw std::runtime_error("robot config '" + yaml_path + "': '" + key + "' needs " + std::to_string(n) +
                               " entries (one per joint)");
  };
  sized(robot.joint_lower_rad, "joint_lower_rad / joint_limits_rad");
  sized(robot.joint_upper_rad, "joint_upper_rad / joint_limits_rad");
  sized(robot.velocity_limit_rad_s, "velocity_limit_rad_s");
  sized(robot.acceleration_limit_rad_s2, "acceleration_limit_rad_s2");
  if (!(robot.link_padding_m >= 0.0))
    throw std::runtime_error("robot config '" + yaml_path + "': 'link_padding_m' must be >= 0");
  if (std::isnan(robot.contact_link_padding_m))
    throw std::runtime_error("robot config '" + yaml_path + "': 'contact_link_padding_m' is not a number");
  for (const std::string& joint : robot.joints)
    if (!robot.home_pose_rad.empty() && robot.home_pose_rad.count(joint) == 0)
      throw std::runtime_error("robot config '" + yaml_path + "': home pose lacks joint '" + joint + "'");
  return robot;
}

}  // namespace fast_grasp
