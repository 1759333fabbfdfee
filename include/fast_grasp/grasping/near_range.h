// The space an object may fill where the camera saw nothing because it was too near.
//
// Beyond the thesis. A depth camera returns no depth nearer than its minimum range (Xtion and
// Kinect: about 0.5 m along the optical axis). An object that reaches closer than that is cut
// there: its view ends at the near limit and the rest of it is invisible, not absent. The
// planners then take the cut for the object's top. In physics (training packed tables,
// session 23) a standing wine bottle and a cracker box seen from 0.45 m up were cut 14-16 cm
// above the table; the fused planner pinched the cut's rim from above and the hand came down
// onto the invisible neck. The unseen part (unseen_part.h) is what hides behind the seen
// surface; this is what may stand in front of the near limit, joined to the points seen at it.
//
// Only the camera's pose and its minimum range are needed, not the depth image: the seen
// points at the limit are where the object goes on, and it can only go on into space nearer
// than the limit. Where exactly is unknown; the blind space assumes the two ways a table-top
// object leaves a downward-looking camera's range: upward (a tall object's top) and along the
// line of sight toward the camera (its near side).
//
// Two uses of the same cut. The blind space as obstacles (add_blind_space) keeps every hand out
// of it, and measured in physics it costs more than it saves: it also blocks neighbours' grasps
// and every grasp of a bottle lying cut toward the camera (docs/clutter.md "Tried: the camera's
// blind zone again"). The lighter use (flag_grasps_on_cut, session 34): a grasp whose fingers
// close on the points at the cut is expected to drop, because the hand comes down onto the
// invisible rest. On the training piles every pinch that touched its object before the
// pre-grasp (8 over six runs: a cracker box or bleach bottle standing, pinched 13-16 mm wide
// on its cut rim) was on an object reaching nearer than the renderer's 0.5 m. The fused
// planner ranks such grasps last (with nothing else they are still a grasp); the hold check
// drops them from a thesis planner's answer (hold_check.h). ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <optional>
#include <string>

namespace fast_grasp
{
/// YAML: top-level `near_range:` of config/grasp_planners.yaml (docs/parameters/grasping.md).
struct NearRangeParams
{
  /// The camera gives no depth nearer than this along its optical axis; 0 = never assume an
  /// object goes on unseen (a camera without a blind zone, or an unknown one).
  double sensor_min_range_m = 0.0;
  /// Add the blind space to each view's obstacles (addNearRangeBlindSpace); off, nothing is
  /// added whatever the range.
  bool add_blind_space = false;
  /// Flag grasps closing on the cut (closesOnNearLimitCut): the fused planner ranks them last,
  /// the hold check drops them.
  bool flag_grasps_on_cut = false;
  /// Seen points at most this much deeper than the limit are at the cut: a cut object has a
  /// line of points right at the limit (within the noise), an object merely near it rarely
  /// reaches this close (2 cm took low objects 1-2 cm beyond it for cut).
  double margin_m = 0.005;
  /// Fewer points at the cut are noise: nothing is assumed.
  std::size_t min_points = 5;
  /// How far the object may go on from the cut, upward and toward the camera.
  double extension_m = 0.15;
  /// Spacing of the blind-space points (one per cube of this size).
  double step_m = 0.005;
  /// Also along each cut point's line of sight toward the camera (an object whose near side,
  /// not its top, was cut), not only upward.
  bool toward_camera = true;
  /// No grasp left because grasps closed on the cut: suggest the camera moved back this far
  /// along its optical axis (nextViewBackFromNearLimit); 0 = no suggestion.
  double next_view_step_back_m = 0.15;

  std::string validate() const;
};

struct NearRangeBlindSpace
{
  CloudXYZ points;          // the blind space (base frame), nearer than the limit
  std::size_t at_limit = 0;  // seen points within margin_m of the limit
};

/// The blind space where the object of `cloud`, seen by a camera at `sensor_origin` looking
/// along the unit `optical_axis`, may go on past the near limit: every seen point within
/// margin_m of the limit, repeated every step_m up to extension_m along `up` (unit, away from
/// the table) and along its line of sight toward the camera, keeping the copies nearer than the
/// limit (farther ones the camera would have seen), one per step_m cube. Empty when fewer than
/// min_points are at the limit or the range is 0.
NearRangeBlindSpace nearRangeBlindSpace(const CloudNormal& cloud, const Eigen::Vector3f& sensor_origin,
                                        const Eigen::Vector3f& optical_axis, const Eigen::Vector3f& up,
                                        const NearRangeParams& params);

/// The camera that took `cloud`: its sensor_origin_ and its sensor_orientation_'s z axis (the
/// optical frame, as CloudPreprocess sets them). None when nobody set them (PCL's defaults:
/// zero origin, identity orientation; e.g. a cloud that crossed a process boundary).
struct CloudCamera
{
  Eigen::Vector3f origin;
  Eigen::Vector3f optical_axis;  // unit
};
std::optional<CloudCamera> cloudCamera(const CloudNormal& cloud);

/// Where the near limit cut the object of `cloud`: its seen points within margin_m of the
/// limit. Empty when flag_grasps_on_cut is off, the range is 0, the cloud carries no camera pose
/// (cloudCamera) or fewer than min_points lie there (most objects: then no grasp is judged).
CloudNormal nearLimitCut(const CloudNormal& cloud, const NearRangeParams& params);

/// Whether `grasp` closes on the cut: at least params.min_points of `cut` (nearLimitCut of its
/// view, computed once for all of a view's grasps) lie between its open fingers (the closing
/// region at full opening, finger-wide).
bool closesOnNearLimitCut(const GraspCandidate& grasp, const GripperModel& gripper, const CloudNormal& cut,
                          const NearRangeParams& params);

/// Beyond the thesis (its next views turn the camera about the object at the same distance,
/// where the near limit cuts the object again): the camera of `cloud` (cloudCamera) moved back
/// params.next_view_step_back_m along its optical axis, its orientation kept, as a camera pose
/// (REP 103 optical axes) in the cloud's frame. From there what reached nearer than the limit is
/// in range when it went on by less than the step (extension_m is the blind space's guess of how
/// far it goes on). For a planner to suggest when every grasp it had closed on the cut. None
/// when the step is 0 or the cloud carries no camera pose.
std::optional<Eigen::Isometry3d> nextViewBackFromNearLimit(const CloudNormal& cloud, const NearRangeParams& params);
/// What a planner's status says when it suggests that view: "next view: the camera 15 cm
/// farther back, beyond the near limit".
std::string nextViewBackFromNearLimitNote(const NearRangeParams& params);

/// Adds the blind space of `view`'s object to view.obstacles, which every planner's hand
/// check keeps out of (and planTableGrasps sweeps each hand's way in against). The camera is
/// the cloud's own sensor_origin_ and sensor_orientation_ (the optical frame: z along the view,
/// as CloudPreprocess sets them); an unset pose (zero origin or identity orientation, e.g. a
/// cloud that crossed a process boundary) adds nothing. "Up" is the table plane's normal, else
/// -gravity. Returns the seen points at the limit (0: nothing added, as when add_blind_space is
/// off).
std::size_t addNearRangeBlindSpace(ObjectView& view, const NearRangeParams& params);

}  // namespace fast_grasp
