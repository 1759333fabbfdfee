// Grasps for every object on a table, and which object to pick first (issue 11, beyond the
// thesis: it grasps one object alone). Each object is planned on its own view by any planner;
// the hand of each grasp, from its pre-grasp to the grasp, must then stay clear of every OTHER
// object's seen points and of the space behind them the camera could not see (their unseen
// parts), since a planner only knows its own object. The object to pick is chosen by an
// explicit rule. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <Eigen/Geometry>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Which object is picked first.
enum class ObjectChoice
{
  BestGrasp,     // the object whose best grasp scores highest (scores of one planner compare); one whose
                 // best grasp has drop_risk after every object whose best grasp does not
  Topmost,       // the highest object first (a pile: taking the top one disturbs the rest least)
  NearestToBase  // the one nearest the robot base (the base frame's origin): the most reachable
};
const char* toString(ObjectChoice choice);
/// "best_grasp", "topmost" or "nearest_to_base"; false for anything else.
bool parseObjectChoice(const std::string& text, ObjectChoice& choice);

/// YAML: `table_grasps:` in config/grasp_planners.yaml (docs/parameters/grasping.md).
struct TableGraspParams
{
  ObjectChoice object_choice = ObjectChoice::BestGrasp;
  /// A neighbour's point (or unseen-part point) nearer than this to the open hand's boxes
  /// blocks the grasp.
  double neighbour_clearance_m = 0.005;
  /// The hand comes in along its approach from this far back (the arm's pre-grasp,
  /// config/arm.yaml `approach_distance_m`): the boxes are swept over that distance.
  double approach_distance_m = 0.10;
  /// Also keep out of the neighbours' unseen parts (what hides behind them may be solid).
  bool neighbour_unseen_parts = true;
  UnseenPartParams unseen;
  /// No object with a grasp: suggest the camera turned this far about the table's normal
  /// through the objects' centre (TableGraspResult::next_view); 0 = no suggestion.
  double next_view_turn_rad = 0.6;
  /// On a table the fused planner returns grasps it expects to drop (its drop-risk tier), and
  /// best_grasp picks their object after every other: tablePlannerConfig (grasp_planner_params.h)
  /// puts this in place of fused/return_drop_risk_grasps, which answers a request for one object.
  bool return_drop_risk_grasps = true;

  std::string validate() const;
};

/// One object's grasps after the neighbour check.
struct ObjectGrasps
{
  std::size_t object = 0;  // index into the views planned
  GraspResult result;      // the planner's result; grasps that hit a neighbour removed
  std::size_t blocked_by_neighbours = 0;  // or by the view's own obstacles (its blind space, near_range.h)
  float top_height_m = 0.0f;      // highest point above the table (the lowest point without one)
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();  // of the seen points
  float base_distance_m = 0.0f;   // centroid's distance from the base frame's origin
  bool ok() const { return !result.grasps.empty(); }
};

struct TableGraspResult
{
  std::vector<ObjectGrasps> objects;  // one per view, in the views' order
  /// Objects with a grasp, in the order object_choice picks them (pick order[0] first).
  std::vector<std::size_t> order;
  /// No object with a grasp (and params.next_view_turn_rad > 0): where to look from next, a
  /// camera pose (REP 103 optical axes) in the views' frame (tableNextView).
  std::optional<Eigen::Isometry3d> next_view;
  double compute_time_s = 0.0;
  bool ok() const { return !order.empty(); }
  const ObjectGrasps& chosen() const { return objects.at(order.at(0)); }
};

/// Plans every view with `planner`, the other views' points and unseen parts (and obstacles of
/// their own, a blind space) within a hand's reach added to its ObjectView::obstacles (its hand
/// check fits its grasps among them), then drops each grasp whose hand, grown by
/// neighbour_clearance_m and swept from the pre-grasp, would still touch them or the view's own
/// obstacles, and orders the objects. Views must share
/// one frame, sensor origins and table plane (one camera frame segmented into objects).
TableGraspResult planTableGrasps(const std::vector<ObjectView>& views, const GraspPlanner& planner,
                                 const GripperModel& gripper, const TableGraspParams& params);

/// Beyond the thesis, whose next view (Ch3.2.3) serves one object: when no object on the table
/// has a grasp from this view, an eye-in-hand camera looks again from beside it. The camera
/// (views' first sensor origin) is turned by `turn_rad` about the table's normal (else against
/// gravity) through the centre of all objects' points, keeping its distance and height, toward
/// the side whose camera is nearer the base frame's origin (the arm stays in reach). Another
/// side shows other faces of touching objects, other cuts between them and other grasps.
/// None without a sensor origin, without finite points or with turn_rad <= 0.
std::optional<Eigen::Isometry3d> tableNextView(const std::vector<ObjectView>& views, double turn_rad);

/// Whether the open hand at `pose`, swept back `approach_distance_m` along its approach and
/// grown by `clearance_m`, contains any of `obstacles` (base-frame points).
bool handSweepHits(const Eigen::Isometry3d& pose, const GripperModel& gripper, const Eigen::Matrix3Xf& obstacles,
                   double approach_distance_m, double clearance_m);

}  // namespace fast_grasp
