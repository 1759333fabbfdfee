// Grasp execution plan: start -> pre-grasp (OMPL) -> straight approach -> grasp -> lift,
// tried best grasp first, time-parameterised. ROS-free.
#pragma once

#include "fast_grasp/arm/arm_kinematics.h"
#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/arm/robot_collision.h"
#include "fast_grasp/arm/robot_config.h"
#include "fast_grasp/arm/trajectory_timing.h"

#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Everything config/arm.yaml and its config/robots/<robot>.yaml hold (README.md, Arm
/// planning; docs/parameters/robots.md). The robot's keys (URDF, links, limits, padding) come
/// only from the robot file and are copied into the fields below.
struct GraspExecutionParams
{
  RobotConfig robot;                     // empty name: arm.yaml named no robot
  std::string urdf_path;                 // empty: the caller supplies the kinematics
  std::string base_link = "base_link";
  std::string tip_link = "grasp_frame";
  Eigen::VectorXd joint_lower_rad;       // empty: the URDF's limits
  Eigen::VectorXd joint_upper_rad;
  Eigen::VectorXd velocity_limit_rad_s;  // empty: the URDF's (pi for the UR5)
  Eigen::VectorXd acceleration_limit_rad_s2;  // empty: 2.0 rad/s^2 per joint
  double approach_distance_m = 0.10;     // pre-grasp stands this far back along the approach axis
  double lift_distance_m = 0.10;         // straight lift (against gravity) after closing
  double cartesian_step_m = 0.005;       // IK + collision check spacing of straight segments
  double max_joint_jump_rad = 0.2;       // larger jumps between Cartesian steps = IK branch flip
  double link_padding_m = 0.005;         // robot shapes inflated by this for planning
  double octomap_resolution_m = 0.01;
  double self_filter_padding_m = 0.02;   // scene points this close to the arm are dropped
  double table_band_m = 0.01;            // scene points this close above the table plane (or under it) are table
  double table_thickness_m = 0.05;       // of the box that replaces them (its top is the fitted plane)
  double total_time_budget_s = 10.0;     // across all grasps tried
  int max_ik_solutions = 8;              // goal set per grasp (ranked by distance from start)
  /// When no grasp works as given, each is tried again with the same closing line reached
  /// differently: the hand turned 180 deg about the approach axis (a two-finger hand grips the
  /// same contacts; only the camera on its side moves), and the approach tilted about the
  /// closing axis in approach_tilt_step_deg steps up to max_approach_tilt_deg (0 = never).
  bool try_flipped_grasp = true;
  double max_approach_tilt_deg = 30.0;
  double approach_tilt_step_deg = 10.0;
  IkParams ik;
  MotionPlanningParams motion;
  TimingLimits timing;                   // velocity/acceleration filled from the fields above
};

/// Loads config/arm.yaml, the robot it names (`robot: ur5` -> robots/ur5.yaml beside it;
/// a non-empty `robot` argument replaces the name) and the planner table from planners_yaml
/// (may be empty). Throws std::runtime_error naming the file and key on a missing file or an
/// invalid value.
GraspExecutionParams loadGraspExecutionParams(const std::string& arm_yaml, const std::string& planners_yaml = "",
                                              const std::string& robot = "");

/// The robot's collision model as configured: URDF chain base -> tip, limits applied, links
/// padded, the object contact links. Throws std::runtime_error on a bad URDF or limit.
RobotCollision makeRobotCollision(const GraspExecutionParams& params);

/// Applies the configured joint/velocity limits to `kinematics`; returns an empty string or why not.
std::string applyLimits(const GraspExecutionParams& params, ArmKinematics& kinematics);

struct GraspPlanResult
{
  bool success = false;
  std::string status;                  // which grasp was used, or why none was
  int grasp_index = -1;                // index into the grasp list, -1 when none
  /// The pose the trajectory ends at: grasps[grasp_index].pose, or a variant of it with the
  /// same closing line (flipped 180 deg about the approach axis, tilted about the closing axis).
  Eigen::Isometry3d executed_pose = Eigen::Isometry3d::Identity();
  bool flipped = false;
  double tilt_rad = 0.0;
  std::string variant;                 // empty: as given; else e.g. "flipped 180 deg about the approach axis"
  std::vector<std::string> joint_names;
  std::vector<TrajectoryPoint> points; // start ... pre-grasp ... grasp ... lifted (rest at each)
  std::size_t pregrasp_point_index = 0;  // points[] index where the arm reaches the pre-grasp
  std::size_t grasp_point_index = 0;     // points[] index where the gripper should close
  std::vector<Eigen::VectorXd> waypoints;  // untimed path (planner waypoints + Cartesian steps)
  std::string planner;
  double planning_time_s = 0.0;
  std::vector<std::string> skipped_reasons;  // "grasp 0: unreachable (no IK solution)", ...
};

/// One perception frame, as the ArmPlanner nodelet receives it (base_link).
struct GraspSceneClouds
{
  const pcl::PointCloud<pcl::PointXYZ>* scene = nullptr;   // everything but the object, table included
  const pcl::PointCloud<pcl::PointXYZ>* object = nullptr;  // the target: only the fingers may touch it
  const pcl::PointCloud<pcl::PointXYZ>* unseen = nullptr;  // space hidden behind the object: target, hand only
  std::optional<Eigen::Vector4f> table_plane;              // a, b, c, d; (a, b, c) from the table up
};

/// Resets `collision`'s scene and fills it from one frame. The table's points become a box
/// whose top is the fitted plane: voxelised, they would raise the table by up to a voxel plus
/// the sensor noise (1-2 cm at 1 cm voxels), which is exactly the clearance a fingertip has
/// in a low grasp. Scene points within table_band_m above the plane (and those under it, down
/// to the box's bottom) are the table; everything else goes to the obstacle OctoMap after the
/// self filter at `robot_state`. The unseen part (self-filtered too) joins the object in the
/// target OctoMap: only the hand may enter it, on the final approach, since the grasp planners
/// fit the hand against it point by point and 5 mm voxels would undo that. Returns a one-line summary.
std::string buildGraspScene(RobotCollision& collision, const Eigen::VectorXd& robot_state,
                            const GraspSceneClouds& clouds, const GraspExecutionParams& params);

/// Plans a grasp motion against the scene held by `collision` (set the scene first:
/// buildGraspScene, or resetScene / addObstacleCloud / setTargetCloud / addBox). Grasps are
/// poses of the grasp frame in base_link (X = approach), best first. First every grasp is
/// tried as given: all its IK solutions (the goal set) whose straight approach from the
/// pre-grasp and lift are clear (and, when none is, the pre-grasp's IK solutions joined to a
/// clear grasp configuration by a straight line). Only when none is reachable and plannable
/// are the grasps tried again, best first, as variants with the same closing line (see
/// GraspExecutionParams::try_flipped_grasp); the status then names the variant. All within
/// params.total_time_budget_s. Never throws on bad input: a wrong-size / NaN / in-collision
/// start or an empty grasp list gives success = false with a status.
GraspPlanResult planGraspMotion(const RobotCollision& collision, const Eigen::VectorXd& start,
                                const std::vector<GraspCandidate>& grasps, const GraspExecutionParams& params);

/// Straight tool-frame line from the tip pose at `from` to `target`, solved step by step with
/// IK seeded by the previous step; every state checked with `options`. Returns the joint path
/// (from first) or empty with `why`.
std::vector<Eigen::VectorXd> planCartesianLine(const RobotCollision& collision, const Eigen::VectorXd& from,
                                               const Eigen::Isometry3d& target, const GraspExecutionParams& params,
                                               const CollisionCheckOptions& options, std::string* why = nullptr);

/// A planning problem (config/benchmarks/*.yaml), shared by bench_planners and the tests.
struct ArmScene
{
  struct Box
  {
    std::string name;
    Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // centre, base_link
  };
  std::string name;
  std::string description;
  std::vector<Box> boxes;
  std::string joints_robot = "ur5";  // the robot (config/robots/) the joint vectors below are for
  Eigen::VectorXd seed_joints;   // IK seed for poses (default: the UR5 home pose)
  Eigen::VectorXd start_joints;  // either start_joints ...
  bool has_start_pose = false;   // ... or a grasp-frame start pose solved by IK
  Eigen::Isometry3d start_pose = Eigen::Isometry3d::Identity();
  std::vector<Eigen::VectorXd> goal_joints;  // either goal joint vectors ...
  bool has_goal_pose = false;                // ... or a grasp-frame goal pose (IK goal set)
  Eigen::Isometry3d goal_pose = Eigen::Isometry3d::Identity();
  bool keep_gripper_horizontal = false;
  double horizontal_tolerance_rad = 0.1;
};

/// Throws std::runtime_error naming the file and key when the scene is malformed.
ArmScene loadArmScene(const std::string& yaml_path);
void addSceneBoxes(const ArmScene& scene, RobotCollision& collision);
/// The scene seen from a robot whose base stands at `robot_base_m` in the scene's frame
/// (RobotConfig::benchmark_base_m): boxes and poses shifted by -robot_base_m. Joint vectors
/// of another robot (scene.joints_robot != robot.name) are replaced by the robot's home pose.
ArmScene sceneForRobot(const ArmScene& scene, const RobotConfig& robot, const std::vector<std::string>& joint_names);
/// Start and goal joint vectors of the scene: poses are solved by IK (the start nearest to the
/// seed; every distinct valid goal solution, nearest to the start first). False with `why`
/// when the start is invalid or no goal is valid under `motion` (collision, constraint).
bool resolveScene(const ArmScene& scene, const ArmMotionPlanner& planner, const MotionPlanningParams& motion,
                  Eigen::VectorXd& start, std::vector<Eigen::VectorXd>& goals, std::string* why = nullptr);

}  // namespace fast_grasp
