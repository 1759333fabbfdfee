// The one mapping from config/grasp_planners.yaml to the planners' parameter structs, shared by
// the offline tool and (once switched over) the grasp nodelets, so a key means the same thing
// everywhere. ROS-free: yaml-cpp only.
#pragma once

#include "fast_grasp/grasping/boundary_grasp.h"
#include "fast_grasp/grasping/concavity_grasp.h"
#include "fast_grasp/grasping/cshape_grasp.h"
#include "fast_grasp/grasping/fused_grasp.h"
#include "fast_grasp/grasping/hold_check.h"
#include "fast_grasp/grasping/near_range.h"
#include "fast_grasp/grasping/principal_axis_grasp.h"
#include "fast_grasp/grasping/table_grasps.h"

#include <yaml-cpp/node/node.h>

#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Reads the `principal_axis:` section (a map; keys as in config/grasp_planners.yaml). Missing
/// keys keep the PrincipalAxisParams defaults; a null node gives the defaults. Throws
/// std::runtime_error naming the key on an unknown key, a value of the wrong type or an
/// invalid value (e.g. a non-positive step, min_points or max_grasps < 1).
PrincipalAxisParams principalAxisParamsFromYaml(const YAML::Node& section);

/// Reads the `cshape:` section the same way; `depth_rule` is "contact_depth" | "cshape_centre",
/// `unseen_*` keys fill CShapeParams::unseen. The result passes CShapeParams::validate() or
/// this throws std::runtime_error with its reason.
CShapeParams cshapeParamsFromYaml(const YAML::Node& section);

/// Reads the `boundary:` section the same way; `unseen_*` keys fill BoundaryParams::unseen. The
/// result passes BoundaryParams::validate() or this throws std::runtime_error with its reason.
BoundaryParams boundaryParamsFromYaml(const YAML::Node& section);
/// Reads the `concavity:` section the same way; `unseen_*` keys fill ConcavityParams::unseen.
/// The result passes ConcavityParams::validate() or this throws std::runtime_error with its
/// reason.
ConcavityParams concavityParamsFromYaml(const YAML::Node& section);

/// Reads the `fused:` section: `planners` (a list of names), the generated candidates, its
/// `gripper_fit:` map and `model: {bias, weights: {feature: weight}}` (the features of
/// grasp_features.h; a missing feature weighs 0). Throws std::runtime_error like the others.
FusedParams fusedParamsFromYaml(const YAML::Node& section);

/// Reads the `table_grasps:` section (planning for every object of a table:
/// `object_choice` best_grasp | topmost | nearest_to_base, the neighbour check). Throws like
/// the others.
TableGraspParams tableGraspParamsFromYaml(const YAML::Node& section);

/// The top-level `hold_check:` section: which thesis planners' grasps pass the hold check
/// (hold_check.h) before they are returned, and whether it includes the tall-object test. The
/// check's values are the fused section's (lying_cylinder, tall_*), so both judge alike.
struct HoldCheckConfig
{
  std::vector<std::string> planners;  // principal_axis, cshape, boundary, concavity (never fused's pool)
  bool tall_objects = false;
  RestingBallParams resting_ball;  // hold_check/resting_ball (the hold check's own: fused ranks by its model)
  StandingCylinderParams standing_cylinder;  // hold_check/standing_cylinder (the hold check's own)
  double max_closing_tilt_rad = 0.0;         // hold_check/max_closing_tilt_rad (0 = no check)
};

/// Reads `hold_check:`. Throws std::runtime_error on another planner name or an unknown key.
HoldCheckConfig holdCheckConfigFromYaml(const YAML::Node& section);

/// Reads the top-level `near_range:` section (the camera's blind zone, near_range.h). Throws
/// like the others.
NearRangeParams nearRangeParamsFromYaml(const YAML::Node& section);

/// The top-level `max_object_extent_m` of grasp_planners.yaml (the root map; a missing key keeps
/// the default). Throws std::runtime_error on a non-positive or unreadable value.
PlannerInputLimits plannerInputLimitsFromYaml(const YAML::Node& root);

/// Every planner's parameters from one grasp_planners.yaml.
struct GraspPlannerConfig
{
  PrincipalAxisParams principal_axis;
  CShapeParams cshape;
  BoundaryParams boundary;
  ConcavityParams concavity;
  FusedParams fused;
  TableGraspParams table_grasps;  // used when every object of a table is planned
  /// Thesis planners wrapped in HoldCheckedPlanner by makeGraspPlanner; never the fused
  /// planner's pooled ones, which it ranks itself.
  HoldCheckConfig hold_check;
  /// The camera's blind zone: where each view is built (grasp_offline, the grasp nodelets),
  /// addNearRangeBlindSpace adds it to the view's obstacles before any planner sees it.
  NearRangeParams near_range;
};

/// Gives every planner of `config` the same input limits.
void setInputLimits(GraspPlannerConfig& config, const PlannerInputLimits& limits);

/// Loads `yaml_path` and maps its `principal_axis:`, `cshape:`, `boundary:`, `concavity:` and
/// `fused:` sections (any may be absent: defaults), `hold_check:`, `near_range:` and the top-level `max_object_extent_m`
/// (every planner's input_limits). The other top-level keys are the nodelets' shared settings
/// and are ignored here. Throws std::runtime_error with the file name on a missing or
/// unparsable file and on any error of the two functions above.
GraspPlannerConfig loadGraspPlannerConfig(const std::string& yaml_path);

/// The config to make the planner of every object of a table with (grasp_offline --all-objects,
/// a grasp nodelet's ~all_objects, bench_clutter): `config` with fused/return_drop_risk_grasps
/// replaced by table_grasps/return_drop_risk_grasps. Asked for one object, a grasp expected to
/// drop is worse than "no stable grasp" and a next view (training singles, sessions 36 and 38:
/// such rank-1 grasps held 1 of 10, 6 touched the object early); on a table its object is picked after
/// every object with a trusted grasp, and without it the clearance ends (training piles,
/// session 36: cleared 189 -> 185 of 205).
GraspPlannerConfig tablePlannerConfig(GraspPlannerConfig config);

/// Every grasp algorithm by its name(): principal_axis, cshape, boundary, concavity, fused.
const std::vector<std::string>& graspAlgorithmNames();

/// The planner named `algorithm` with its section of `config`; nullptr for an unknown name.
/// The one place the tools turn a name into a planner.
std::unique_ptr<GraspPlanner> makeGraspPlanner(const std::string& algorithm, const GraspPlannerConfig& config);

}  // namespace fast_grasp
