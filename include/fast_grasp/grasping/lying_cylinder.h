// A round object lying on the table (a can, a bottle, a rolling pin) found in one partial view,
// and whether a grasp's fingers reach past its axis.
//
// Beyond the thesis. In physics (training half, session 20) grasps closing across a lying
// cylinder held 91 % of the time when the fingertips passed its axis and 49 % when they
// stopped short of it: the flat finger pads then touch above the widest section, at their
// very tips, and the squeeze shoots the object out sideways or it slips on the lift. The
// thesis planners (concavity above all) put the closing line where they saw the contacts, the
// top and the camera-facing side, and an oblique hand stops short there.
//
// The fit uses what a single view of a lying round object does give: its axis is horizontal,
// along the footprint's major axis, and lies one radius above the table, where the radius is
// half the object's height. The one unknown left is the axis's position across the footprint:
// where the circle fits the seen points best, found by a 1-D scan. A general cylinder RANSAC
// (PCL's SACMODEL_CYLINDER) has five unknowns for the same half-circle of points, with normals
// that are noisiest exactly where the half-circle ends; the table fixes three of them. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/grasp_features.h"

#include <Eigen/Core>

#include <limits>
#include <optional>
#include <string>

namespace fast_grasp
{
struct LyingCylinderParams
{
  /// Look for a lying round object at all (false: never found, nothing is demoted).
  bool enabled = false;
  /// The seen points must span at least this many times the object's height along the axis: a
  /// cheap first test (a can half hidden in a pile is seen shorter than it is wide; the tests
  /// below tell a standing can).
  double min_length_to_height = 0.6;
  /// The side's normals square to one horizontal axis: their horizontal parts' least spread
  /// over their most (0 on a lying cylinder, ~1 on a standing one or a sphere).
  double max_normal_spread_ratio = 0.1;
  /// Round, not a box: the seen points' median distance from the fitted circle, as a fraction
  /// of the radius (a lying box's top corners lie up to 0.4 radius off its circle; a bottle's
  /// neck is a minority of its points), and the median angle between their normals and the
  /// direction away from the axis (a box's faces: up to 45 deg).
  double max_median_residual_frac = 0.18;
  double max_median_normal_angle_rad = 0.22;
  /// Fewest finite points the fit needs.
  std::size_t min_points = 30;
  /// A grasp closing across the axis (fingertipReachPastAxis) whose fingertips pass the axis
  /// by less than this (negative: may stop that far short of it), measured along the approach
  /// in the cross-section, falls short of the axis.
  double min_fingertip_reach_m = 0.0;
  /// A grasp closing across the axis whose open hand, on its way in from open_hand_approach_m
  /// back along the approach, would reach deeper than this into the fitted cylinder
  /// (openHandDepthInCylinder) lands on the object's hidden side before it closes.
  double max_open_hand_depth_m = std::numeric_limits<double>::infinity();
  double open_hand_approach_m = 0.1;

  std::string validate() const;
};

struct LyingCylinder
{
  bool found = false;
  Eigen::Vector3f axis_point = Eigen::Vector3f::Zero();  // on the axis, at the seen points' middle along it
  Eigen::Vector3f axis = Eigen::Vector3f::UnitX();       // unit, horizontal
  float radius_m = 0.0f;
  float half_length_m = 0.0f;            // half the seen points' span along the axis (about axis_point)
  float median_residual_m = 0.0f;        // median |distance from the axis - radius| of the seen points
  float median_normal_angle_rad = 0.0f;  // median angle of their normals to the radial direction
  float normal_spread_ratio = 1.0f;      // least over most spread of the normals' horizontal parts (the body's where it is long)
  std::string why;                       // when not found: which test failed
};

/// Fits a lying round object to `view` (extent: objectExtent(view)). Found only with a table
/// plane (the radius is half the height above it).
LyingCylinder fitLyingCylinder(const ObjectView& view, const ObjectExtent& extent, const LyingCylinderParams& params);

/// How far the fingertips of `grasp` pass the axis of `cylinder`, measured along the grasp's
/// approach projected into the cylinder's cross-section (negative: they stop short). Empty
/// when the grasp does not close across the axis (its closing direction less than 30 deg from
/// the axis, or its approach less than 45 deg from it: an end-on grasp) or nothing was found.
std::optional<float> fingertipReachPastAxis(const GraspCandidate& grasp, const GripperModel& gripper,
                                            const LyingCylinder& cylinder);

/// How deep the open hand of `grasp` (fingers open to `opening_m`, and the palm: the boxes of
/// openGripperBoxes) reaches into `cylinder` at the grasp pose or anywhere on the straight
/// approach from `approach_m` back along -approach: the radius minus the least distance of
/// the hand from the axis (positive: inside), over the boxes whose span along the axis meets
/// the seen length (minus infinity when none does). Empty under fingertipReachPastAxis's
/// conditions.
/// Why: the gripper-volume check sees the seen points and a shadow, but a lying round
/// object's far side is hidden and the fit knows where it is; a hand offset from the axis
/// lands its far finger on it (training piles, session 21).
std::optional<float> openHandDepthInCylinder(const GraspCandidate& grasp, const GripperModel& gripper,
                                             const LyingCylinder& cylinder, double opening_m, double approach_m);

/// What a lying round object does to a grasp (LyingCylinderParams' two tests, in this order).
enum class GraspAcrossCylinder
{
  NotAcross,       // nothing found, or the grasp does not close across the axis (end-on, along it)
  Holds,           // passes both tests
  ShortOfAxis,     // fingertips pass the axis by less than min_fingertip_reach_m
  OntoHiddenSide,  // the open hand reaches deeper than max_open_hand_depth_m into the cylinder
};

/// Judges `grasp` against `cylinder` with `params`' two thresholds; the open hand is open to
/// `opening_m` on its way in. The fused planner ranks ShortOfAxis and OntoHiddenSide grasps
/// last, the hold check (hold_check.h) drops them.
GraspAcrossCylinder judgeGraspAcrossCylinder(const GraspCandidate& grasp, const GripperModel& gripper,
                                             const LyingCylinder& cylinder, const LyingCylinderParams& params,
                                             double opening_m);

}  // namespace fast_grasp
