// The robot an ArmPlanner plans for, read from config/robots/<name>.yaml: which URDF, which
// chain, limits, padding, home pose and the links allowed to touch the object. One YAML and a
// URDF make a new arm; no code names a robot. ROS-free.
#pragma once

#include <Eigen/Core>

#include <map>
#include <string>
#include <vector>

namespace fast_grasp
{
struct RobotConfig
{
  std::string name;                  // the file's stem: ur5, lwr4, jaco
  std::string urdf_path;             // absolute (relative paths in the YAML are resolved against its folder)
  std::string base_link = "base_link";
  std::string tip_link = "grasp_frame";
  std::string camera_link;           // eye-in-hand camera (tf root of the Xtion's frames)
  std::vector<std::string> joints;   // planning group, in chain order
  std::string home_pose_path;        // joint name -> rad (joint_state_publisher's ~zeros file)
  std::map<std::string, double> home_pose_rad;
  Eigen::VectorXd joint_lower_rad;   // empty: the URDF's limits
  Eigen::VectorXd joint_upper_rad;
  Eigen::VectorXd velocity_limit_rad_s;       // empty: the URDF's
  Eigen::VectorXd acceleration_limit_rad_s2;  // empty: 2 rad/s^2 per joint
  double link_padding_m = 0.005;
  std::vector<std::string> object_contact_links = { "left_finger_link", "right_finger_link" };
  /// The object_contact_links are inflated by this instead of link_padding_m; < 0 = the same.
  /// Why: a finger's shape is known to the millimetre, and a 5 mm pad kept fingertips 6 mm
  /// above the table, where they close on a lying pen or battery at its equator and it slips out.
  double contact_link_padding_m = -1.0;
  /// Where this robot's base stands in the benchmark scenes (config/benchmarks/, laid out
  /// around the UR5 at the origin), m: an arm of longer reach stands further back.
  Eigen::Vector3d benchmark_base_m = Eigen::Vector3d::Zero();
  /// OMPL planner parameters for this arm, planner -> parameter -> value, laid over
  /// config/planners.yaml's (a range tuned for one arm's joint space is not another's).
  std::map<std::string, std::map<std::string, std::string>> planner_parameters;

  /// Home pose in the order of `joint_names`; throws std::runtime_error naming a missing joint.
  Eigen::VectorXd homePose(const std::vector<std::string>& joint_names) const;
};

/// config/robots/<name>.yaml under `config_dir`.
std::string robotConfigPath(const std::string& config_dir, const std::string& name);

/// Throws std::runtime_error naming the file and key on a missing file or a bad value.
RobotConfig loadRobotConfig(const std::string& yaml_path);

}  // namespace fast_grasp
