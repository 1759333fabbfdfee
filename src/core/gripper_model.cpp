#include "fast_grasp/core/gripper_model.h"

#include "fast_grasp/core/yaml_file.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace fast_grasp
{
std::string GripperModel::validate() const
{
  std::ostringstream why;
  // No hand is larger than a metre; a fuzzed C-shape radius of 15 km made the C-shape
  // planner's shallow-placement search step through 15 km in 5 mm steps (docs/tests.md).
  constexpr double kLargestDimensionM = 1.0;
  auto positive = [&](const char* key, double value) {
    if (!(std::isfinite(value) && value > 0.0 && value <= kLargestDimensionM))
      why << key << " must be a positive number of metres up to " << kLargestDimensionM << " (got " << value << "); ";
  };
  positive("max_opening_m", max_opening_m);
  positive("finger_width_m", finger_width_m);
  positive("finger_thickness_m", finger_thickness_m);
  positive("finger_depth_m", finger_depth_m);
  positive("hand_depth_m", hand_depth_m);
  positive("palm_thickness_m", palm_thickness_m);
  positive("cshape_r1_m", cshape_r1_m);
  positive("cshape_r2_m", cshape_r2_m);
  positive("cshape_w_m", cshape_w_m);
  if (!(std::isfinite(palm_width_m) && palm_width_m >= 0.0))
    why << "palm_width_m must be >= 0 (0 = twice the finger width); ";
  if (!(std::isfinite(min_opening_m) && min_opening_m >= 0.0 && min_opening_m < max_opening_m))
    why << "min_opening_m must lie in [0, max_opening_m); ";
  if (cshape_r2_m <= cshape_r1_m)
    why << "cshape_r2_m must exceed cshape_r1_m (Eq. 6.1: outer radius > inner radius); ";
  return why.str();
}

GripperModel loadGripperModel(const std::string& yaml_path)
{
  YAML::Node root;
  try
  {
    root = loadYamlFile(yaml_path);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("cannot read gripper file '" + yaml_path + "': " + e.what());
  }
  GripperModel model;
  auto read = [&](const char* key, double& value, bool required) {
    if (!root[key])
    {
      if (required)
        throw std::runtime_error("gripper file '" + yaml_path + "' lacks required key '" + key + "'");
      return;
    }
    try
    {
      value = root[key].as<double>();
    }
    catch (const YAML::Exception&)
    {
      throw std::runtime_error("gripper file '" + yaml_path + "': key '" + key + "' is not a number");
    }
  };
  model.name = root["name"] ? root["name"].as<std::string>() : yaml_path;
  read("max_opening_m", model.max_opening_m, true);
  read("min_opening_m", model.min_opening_m, false);
  read("finger_width_m", model.finger_width_m, true);
  read("finger_thickness_m", model.finger_thickness_m, true);
  read("finger_depth_m", model.finger_depth_m, true);
  read("hand_depth_m", model.hand_depth_m, true);
  read("palm_thickness_m", model.palm_thickness_m, false);
  read("palm_width_m", model.palm_width_m, false);
  read("cshape_r1_m", model.cshape_r1_m, true);
  read("cshape_r2_m", model.cshape_r2_m, true);
  read("cshape_w_m", model.cshape_w_m, true);
  if (root["underactuated"])
    model.underactuated = root["underactuated"].as<bool>();
  const std::string problem = model.validate();
  if (!problem.empty())
    throw std::runtime_error("gripper file '" + yaml_path + "': " + problem);
  return model;
}

}  // namespace fast_grasp
