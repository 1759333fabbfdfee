// A ball resting on the table (an orange, a tennis ball, a plum) found in one partial view,
// and how far a grasp's fingertips reach into it.
//
// Beyond the thesis. In physics (training objects, fresh camera draws, session 25) the thesis
// planners' grasps on balls dropped them whenever the fingertips stopped high on the ball: the
// flat pads then touch it with their very tips, above its widest section, and the squeeze or
// the shake pops it out. Top grasps of every planner held (97-100 %) once the fingertips were
// 25 mm into a large ball (8 cm: still 15 mm above its centre), and on small balls (3-4 cm)
// only once they passed the centre; 5-10 mm less and they held 0-69 %.
//
// The fit uses what a single view of a resting ball gives: its centre is one radius above the
// table and the radius is half its height. What is left is the centre's position on the table,
// where the sphere fits the seen points best: a 2-D scan, as lying_cylinder.h does across its
// axis. (PCL's SACMODEL_SPHERE has four unknowns for the same cap of points seen from above.)
// A longer footprint (up to max_length_to_height) is fitted the same way as an ellipsoid: the
// footprint's axes are scaled to the height, where it is a ball (session 26: a flat pebble,
// 9 x 7 x 4 cm, was the thesis planners' most dropped training object on a fresh draw, with the
// tips at or above its rim; the held-out half has an egg).
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/grasp_features.h"

#include <Eigen/Core>

#include <cstddef>
#include <string>

namespace fast_grasp
{
struct RestingBallParams
{
  /// Look for a resting ball at all (false: never found, nothing is judged).
  bool enabled = false;
  /// Round about one centre, not a box or a can: the seen points' median distance from the
  /// fitted sphere as a fraction of its radius, and the median angle between their normals and
  /// the direction away from the centre (a cube's faces: up to 55 deg off it).
  double max_median_residual_frac = 0.12;
  double max_median_normal_angle_rad = 0.3;
  /// Fewest finite points with normals the fit needs.
  std::size_t min_points = 30;
  /// The fingertips must reach at least this far into the ball, measured along the approach
  /// from the ball's near side, or pass its centre (whichever is less deep).
  double min_fingertip_depth_m = 0.025;
  /// A footprint up to this many times longer than the object is high is still a round body:
  /// beyond 1.25 it is fitted as an ellipsoid standing on the table (half-axes: half the
  /// footprint's length and breadth, half the height; a flat pebble, an egg, a lemon on its
  /// side), whose fingertip depth is measured along the approach to its surface. 1.25 = balls only.
  double max_length_to_height = 1.25;
  /// A flat round body (at most this many times as high as its footprint is broad: a pebble,
  /// not a ball or a lemon) held by the fingertips' edges at its rim swings out about the line
  /// between the two contacts; its grasps must put the tips this fraction of its vertical
  /// half-axis past its centre along the approach (the pads then close on the rim with their
  /// faces). 0 = no extra depth for flat bodies.
  double flat_max_height_to_breadth = 0.75;
  double flat_min_fingertip_past_centre_frac = 0.0;

  std::string validate() const;
};

struct RestingBall
{
  bool found = false;
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  float radius_m = 0.0f;  // the vertical half-axis (half the height): the radius of a ball
  /// Horizontal half-axes along major_axis and across it (up x major_axis); both radius_m for
  /// a ball, zero when not fitted (radiusAlong then uses radius_m).
  Eigen::Vector2f horizontal_half_axes_m = Eigen::Vector2f::Zero();
  Eigen::Vector3f major_axis = Eigen::Vector3f::UnitX();
  Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  float median_residual_m = 0.0f;        // median |distance from the centre - radius| of the seen points
  float median_normal_angle_rad = 0.0f;  // median angle of their normals to the radial direction
  std::string why;                       // when not found: which test failed
};

/// Fits a ball resting on the table to `view` (extent: objectExtent(view)). Found only with a
/// table plane (the radius is half the height above it).
RestingBall fitRestingBall(const ObjectView& view, const ObjectExtent& extent, const RestingBallParams& params);

/// The body's radius along unit direction `direction` (centre to surface): radius_m for a ball.
float radiusAlong(const RestingBall& ball, const Eigen::Vector3f& direction);

/// How far the fingertips of `grasp` (finger_depth_m / 2 ahead of its centre) pass the centre of
/// `ball` along the approach (negative: they stop short of it). Not meaningful unless found.
float fingertipReachPastCentre(const GraspCandidate& grasp, const GripperModel& gripper, const RestingBall& ball);

/// A found body at most `params.flat_max_height_to_breadth` times as high as its footprint's
/// narrower half-axis is broad (a ball's fit, whose half-axes are all its radius, never is).
bool isFlatRoundBody(const RestingBall& ball, const RestingBallParams& params);
/// A grasp whose fingertips stop short of `params.min_fingertip_depth_m` into a found ball and
/// short of its centre, or, on a flat body, less than `flat_min_fingertip_past_centre_frac` of
/// its vertical half-axis past its centre: false when nothing was found.
bool fingertipsStopHighOnBall(const GraspCandidate& grasp, const GripperModel& gripper, const RestingBall& ball,
                              const RestingBallParams& params);

}  // namespace fast_grasp
