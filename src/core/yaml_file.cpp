#include "fast_grasp/core/yaml_file.h"

#include <filesystem>
#include <system_error>

namespace fast_grasp
{
YAML::Node loadYamlFile(const std::string& path)
{
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw YAML::BadFile(path);
  return YAML::LoadFile(path);
}

}  // namespace fast_grasp
