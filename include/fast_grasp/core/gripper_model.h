// Gripper geometry as configuration (config/grippers/*.yaml). ROS-free.
#pragma once

#include <string>

namespace fast_grasp
{
/// Geometry every planner needs. The C-shape fields follow Eq. 6.1 of the thesis:
/// the gripper seen along its closing plane is a C of inner radius r1, outer radius r2
/// and width w (finger thickness across the closing plane).
struct GripperModel
{
  std::string name;
  double max_opening_m = 0.085;   // largest distance between the fingertips
  double min_opening_m = 0.0;     // smallest graspable width
  double finger_width_m = 0.02;   // finger size across the closing direction (contact patch)
  double finger_thickness_m = 0.01;  // finger size along the closing direction
  double finger_depth_m = 0.04;   // usable finger length along the approach
  double hand_depth_m = 0.06;     // palm-to-fingertip depth of the closing region
  double palm_thickness_m = 0.03; // palm size along the approach behind the fingers
  double palm_width_m = 0.0;      // palm size across the closing plane; 0 = 2 * finger_width_m
  double cshape_r1_m = 0.045;     // Eq. 6.1 inner radius (half the opening region)
  double cshape_r2_m = 0.06;      // Eq. 6.1 outer radius (inner radius + finger thickness)
  double cshape_w_m = 0.02;       // Eq. 6.1 width of the C across its plane
  bool underactuated = false;     // the fingers wrap (Lacquey Fetch) rather than stay parallel

  /// Palm size across the closing plane (palm_width_m, or twice the finger width when unset).
  double palmWidth() const { return palm_width_m > 0.0 ? palm_width_m : 2.0 * finger_width_m; }

  /// Returns an empty string when the model is usable, else why not.
  std::string validate() const;
};

/// Loads a gripper from a YAML file; throws std::runtime_error with the file name and the
/// offending key on a missing file, a missing key or an invalid value.
GripperModel loadGripperModel(const std::string& yaml_path);

}  // namespace fast_grasp
