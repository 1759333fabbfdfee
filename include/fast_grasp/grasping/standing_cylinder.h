// A tall round object standing on the table (a wine bottle, a juice bottle, a big jar) seen at
// one height in one partial view, and whether a side grasp's fingertips get near its axis there.
//
// Beyond the thesis. In physics (training half, session 27: the thesis planners' top 8 grasps
// on two camera draws, 3 poses each) side grasps on a standing 7.4 cm wine bottle held 2 times
// in 98 when the fingertips stopped 0.3-0.5 radius short of its axis, and on a 6.6 cm water
// bottle (21 cm) 68 %; every grasp whose fingertips reached within 0.2 radius of the axis held
// (97-100 % over all standing round objects). A 2F-85's 40 mm fingers behind the palm's 11 mm
// clearance cannot reach the axis of a bottle that wide: the pads close on a chord near their
// tips, where the surface turns toward the palm, and the squeeze pushes the bottle out of the
// hand while its weight pulls it down. Short objects hold such chord grasps (a soup can,
// 10 cm: 92 of 92), so only tall ones are judged. The lying case is lying_cylinder.h's.
//
// The fit is local: a bottle is a cylinder only below its shoulder, so the circle is fitted to
// the seen points in a band around the grasp's closing height (their projection on the table
// plane, an algebraic least-squares circle: 3 unknowns, one linear solve), and it counts only
// when they lie on it, their normals point away from its centre and they span enough of it.
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/grasp_features.h"

#include <Eigen/Core>

#include <cstddef>
#include <optional>
#include <string>

namespace fast_grasp
{
struct StandingCylinderParams
{
  /// Judge side grasps on standing round objects at all (false: nothing is judged).
  bool enabled = false;
  /// Objects at least this high are judged (a short can holds a chord grasp).
  double min_height_m = 0.18;
  /// Seen points within this of the grasp's closing height (along the table normal) are the
  /// section the circle is fitted to.
  double band_half_height_m = 0.015;
  /// Fewest of them the fit needs.
  std::size_t min_points = 20;
  /// Round: their median distance from the fitted circle, as a fraction of its radius, and the
  /// median angle between their normals (projected on the table plane) and the direction away
  /// from its centre; and they span at least this angle of it, seen from its centre (a flat
  /// face fits a huge circle over a small angle).
  double max_median_residual_frac = 0.08;
  double max_median_normal_angle_rad = 0.3;
  double min_arc_rad = 1.2;
  /// A side grasp whose fingertips stop more than this fraction of the radius short of the
  /// axis (along the approach's horizontal part) is judged to drop the object.
  double max_shortfall_frac = 0.2;

  std::string validate() const;
};

/// The round section of a standing object at one height.
struct StandingSection
{
  bool found = false;
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();  // on the axis, at the section's height
  float radius_m = 0.0f;
  float median_residual_m = 0.0f;
  float median_normal_angle_rad = 0.0f;
  float arc_rad = 0.0f;  // angle the seen points span about the centre
  std::string why;       // when not found: which test failed
};

/// The section of `view` (extent: objectExtent(view)) at `height_m` above the table. Found only
/// with a table plane.
StandingSection fitStandingSection(const ObjectView& view, const ObjectExtent& extent, float height_m,
                                   const StandingCylinderParams& params);

/// A side grasp: approach within 45 deg of the table plane, closing within 30 deg of it.
bool isSideGrasp(const GraspCandidate& grasp, const ObjectExtent& extent);

/// How far the fingertips of `grasp` (finger_depth_m / 2 ahead of its centre) pass the
/// section's axis along the approach's part in the table plane (negative: they stop short).
float fingertipReachPastStandingAxis(const GraspCandidate& grasp, const GripperModel& gripper,
                                     const StandingSection& section, const Eigen::Vector3f& up);

/// The section a side grasp on a tall object closes at, when its fingertips stop more than
/// max_shortfall_frac x its radius short of its axis; empty otherwise (not enabled, not tall,
/// not a side grasp, no round section there, or the fingertips get near enough).
std::optional<StandingSection> standingSectionMissed(const GraspCandidate& grasp, const GripperModel& gripper,
                                                     const ObjectView& view, const ObjectExtent& extent,
                                                     const StandingCylinderParams& params);

}  // namespace fast_grasp
