// Joint-space motion planning with OMPL for a URDF chain, collision-checked by RobotCollision.
// ROS-free; OMPL types appear only as forward declarations here.
#pragma once

#include "fast_grasp/arm/robot_collision.h"

#include <Eigen/Core>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace ompl
{
namespace base
{
class Planner;
class SpaceInformation;
}  // namespace base
namespace geometric
{
class SimpleSetup;
}  // namespace geometric
}  // namespace ompl

namespace fast_grasp
{
/// Planner parameters by OMPL planner name, then OMPL parameter name -> value
/// (config/planners.yaml; defaults are the thesis's Table 6.2).
using PlannerParameterTable = std::map<std::string, std::map<std::string, std::string>>;

struct MotionPlanningParams
{
  std::string planner = "RRTConnect";  // any of ArmMotionPlanner::plannerNames(); see config/arm.yaml
  double planning_time_s = 3.0;              // budget for solve(); simplification comes out of it too
  double simplify_time_s = 0.2;              // at most this for path simplification
  bool simplify = true;
  /// Motion validation step as a fraction of the joint space's extent (OMPL / MoveIt
  /// longest_valid_segment_fraction; the thesis keeps MoveIt's 0.005).
  double longest_valid_segment_fraction = 0.005;
  /// The fraction above is 0.005 x 15.4 rad = 0.077 rad for a UR5 with +-pi limits: up to
  /// 7 cm at the hand between checked states. The sound validator also bounds the Cartesian
  /// step: no robot point moves more than max_cartesian_step_m between checked states (bound
  /// from RobotCollision::jointLeverArms()); with shapes padded by p, a step below 2 p cannot
  /// skip over an obstacle. 0 = OMPL's fraction alone (the thesis's setting).
  double max_cartesian_step_m = 0.01;
  /// Plan with the fraction alone (fast), then check the path with the sound validator and
  /// re-plan failing segments locally (see ArmMotionPlanner::plan). false = sound validator
  /// inside the planner (slower; what bench_planners --sound measures).
  bool lazy_validation = true;
  /// Keep the gripper horizontal: the grasp frame's Z axis (normal of the closing plane)
  /// stays within horizontal_tolerance_rad of the vertical at every state the planner and
  /// the motion validator check (the held object stays upright).
  bool keep_gripper_horizontal = false;
  double horizontal_tolerance_rad = 0.1;
  PlannerParameterTable planner_params;
};

enum class MotionPlanStatus
{
  Success,
  InvalidInput,    // wrong joint count, NaN, empty goal list
  UnknownPlanner,  // name not in plannerNames()
  StartInvalid,    // start in collision, outside limits or violating the constraint
  GoalInvalid,     // every goal is in collision / outside limits / violating the constraint
  NoPath           // no exact solution within the time budget (approximate = failure)
};
const char* toString(MotionPlanStatus status);

struct MotionPlanResult
{
  MotionPlanStatus status = MotionPlanStatus::InvalidInput;
  std::string message;
  std::vector<Eigen::VectorXd> path;  // start ... goal (one of the goals), simplified
  double planning_time_s = 0.0;       // solve + simplify
  double path_length_rad = 0.0;       // joint-space length
  int repaired_segments = 0;          // segments re-planned by the sound validator
  bool ok() const { return status == MotionPlanStatus::Success; }
};

/// Plans collision-free joint paths. Holds a snapshot of the collision model + scene; plan()
/// is const and may run concurrently (the validity checker is stateless).
class ArmMotionPlanner
{
public:
  /// Also lowers OMPL's process-wide log level to WARN when it is more verbose: OMPL's
  /// default DEBUG output made SBL 10-50x slower here (3-14 ms vs 0.1-0.3 s per query).
  explicit ArmMotionPlanner(const RobotCollision& collision);

  /// The thesis's 23 OMPL geometric planners (Table 6.1), by OMPL name.
  static const std::vector<std::string>& plannerNames();

  /// Plans from start to the nearest reachable of `goals` (an OMPL goal set).
  MotionPlanResult plan(const Eigen::VectorXd& start, const std::vector<Eigen::VectorXd>& goals,
                        const MotionPlanningParams& params) const;

  /// State validity as the planner sees it (limits, collision, optional constraint).
  bool isValid(const Eigen::VectorXd& q, const MotionPlanningParams& params, std::string* why = nullptr) const;
  /// isValid of `count` states in order, up to the first invalid one: its index, or count
  /// when all are valid (the states after it are not checked). The same verdicts; the
  /// collision tests of several states share their forward kinematics
  /// (RobotCollision::firstInCollision).
  std::size_t firstInvalid(const Eigen::VectorXd* const* qs, std::size_t count, const MotionPlanningParams& params) const;
  /// Angle (rad) between the grasp frame's Z axis and the vertical (sign-agnostic).
  double gripperTiltRad(const Eigen::VectorXd& q) const;

  /// For benchmarks (ompl::tools::Benchmark): a SimpleSetup with the space, validity checker,
  /// motion resolution, start and goals configured; the planner is left unset.
  std::shared_ptr<ompl::geometric::SimpleSetup> makeSetup(const Eigen::VectorXd& start,
                                                          const std::vector<Eigen::VectorXd>& goals,
                                                          const MotionPlanningParams& params) const;
  /// Allocates a planner by name with its parameters from params.planner_params; unknown
  /// parameter names are appended to `unknown_params` (null planner for an unknown name).
  static std::shared_ptr<ompl::base::Planner> allocatePlanner(const std::string& name,
                                                              const std::shared_ptr<ompl::base::SpaceInformation>& si,
                                                              const PlannerParameterTable& table,
                                                              std::vector<std::string>* unknown_params = nullptr);

  const RobotCollision& collision() const { return collision_; }

private:
  RobotCollision collision_;
};

/// Reads config/planners.yaml: { PlannerName: { param: value, ... }, ... }. Throws
/// std::runtime_error naming the file on a missing file or a malformed entry.
PlannerParameterTable loadPlannerParameters(const std::string& yaml_path);

}  // namespace fast_grasp
