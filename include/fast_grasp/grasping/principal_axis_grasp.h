// Principal-axis grasp planner of thesis Chapter 3: single view (Ch3.2, steps 1-7 and the
// next-viewpoint rule of Ch3.2.3) and two cameras with virtual viewpoints (Ch3.5). The next
// view's rotations about the principal axis (Eq. 3.6) live in principal_axis_next_view.h.
// ROS-free: C++17, Eigen, PCL point types.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/core/gripper_model.h"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace fast_grasp
{
struct PrincipalAxisParams
{
  /// Delta y of Eq. 3.4: spacing of the sweep lines along the principal axis.
  double sweep_step_m = 0.002;
  /// Cell of the 2-D occupancy grid that stands in for the concave hull (XOY projection).
  double grid_cell_m = 0.002;
  /// Empty grid rows bridged by interpolating their neighbours' extremes (sensor holes).
  int gap_close_rows = 2;
  /// A sweep line's crossings are the extremes over its grid row and this many rows either
  /// side, so a row whose outermost point is missing (sparse or noisy scan) is not read narrow.
  int crossing_window_rows = 1;
  /// A point belongs to a grasp side (contact region, Eq. 3.9) when it lies within this
  /// distance of its row's left-most / right-most point in the XOY projection.
  double side_depth_m = 0.005;
  /// The finger band of a candidate must stay this far from both ends of the object along
  /// the principal axis: there the contour turns (caps, rims, and with a tilted axis the last
  /// rings project as arcs), which bends both side lines inward and fakes parallel sides.
  double end_clearance_m = 0.01;
  /// Step 6 threshold on the XOY force-balance angle (see Grasp::force_balance_rad below).
  double force_balance_max_rad = 0.35;
  /// Step 7 threshold Z_dif max on |Z1 - Z2| (Eq. 3.10).
  double xoz_max_offset_m = 0.005;
  /// Below this angle between the principal axis and the line of sight the object frame of
  /// Eq. 3.3 is ill-defined (the thesis's "principal axis cannot be obtained" risk).
  double min_axis_view_angle_rad = 0.26;
  /// Standard deviations (sqrt of PCA eigenvalues) below this mark a collinear (second axis)
  /// or flat (third axis) cloud: no closing direction can be derived.
  double min_thickness_m = 0.0005;
  std::size_t min_points = 10;
  /// Ch3.5: use the virtual viewpoints between two sensor origins when the view has two.
  bool two_camera_mode = true;
  /// Delta theta of Ch3.5.2 between virtual viewpoints.
  double virtual_view_step_rad = 0.1745329;  // 10 degrees
  /// Beyond the thesis's step-7 rule: when every stable grasp is ruled out by the table (a low
  /// object seen from the side), suggest the view from above (the rotation of Eq. 3.6 about
  /// the principal axis that brings the line of sight nearest to vertical).
  bool next_view_from_above = true;
  /// Smaller turns are not suggested (the camera already looks from about there).
  double next_view_min_turn_rad = 0.0873;  // 5 degrees
  /// No graspable zone (thesis risk 2): the view along the seen face (Fig. 3.11 b) is suggested
  /// when that face is wider than the opening and flat, its RMS distance from its XOZ line
  /// below this fraction of its width (a flat face ~0.01-0.03, a seen half cylinder ~0.15).
  double next_view_max_face_rms_ratio = 0.08;
  /// At most this many grasps are returned (best first).
  std::size_t max_grasps = 20;
  /// Final check with the real hand's volume (gripper_volume.h): palm backed out of the
  /// object, fingers free, object between them.
  GripperFitParams gripper_fit;

  /// The top-level keys of config/grasp_planners.yaml (loadGraspPlannerConfig, the nodelets).
  PlannerInputLimits input_limits;

  /// Empty when every step, cell and threshold is usable; otherwise what is wrong.
  std::string validate() const;
};

/// One sweep line y = y_min + n * delta_y (Eq. 3.4) in the object frame and its left-most and
/// right-most crossing with the projected contour; z_* are the depths (object Z) of the
/// crossing points.
struct SweepLine
{
  double y_m = 0.0;
  bool hit = false;  // false when the line misses the contour (a hole wider than the gap closing)
  double left_x_m = 0.0;
  double right_x_m = 0.0;
  double left_z_m = 0.0;
  double right_z_m = 0.0;
  double widthM() const { return right_x_m - left_x_m; }
};

/// Step 4-5 without PCL's ConcaveHull: rasterises the XOY projection of `object_points`
/// (object-frame x, y, z) into rows of `grid_cell_m`, bridges up to `gap_close_rows` empty
/// rows, takes each row's extremes over `crossing_window_rows` rows either side and returns
/// one SweepLine every `sweep_step_m` from y_min to y_max. When
/// `boundary_xy` is given it receives the centres of the boundary cells of the (closed)
/// occupancy grid: the contour drawn in place of the thesis's concave hull.
/// Returns no lines for empty input or non-positive steps.
std::vector<SweepLine> sweepProjectedContour(const std::vector<Eigen::Vector3f>& object_points, double sweep_step_m,
                                             double grid_cell_m, int gap_close_rows, int crossing_window_rows,
                                             std::vector<Eigen::Vector2f>* boundary_xy = nullptr);

/// Ch3.5.2: virtual viewpoints q_theta_i = q_theta_0 + i * delta_theta, rotating `origin_a`
/// about the axis (through `centroid`, along `axis`) toward `origin_b`;
/// floor(angle / step) + 1 of them, angle being the angle between the two origins seen
/// along the axis. Empty when an origin lies on the axis or the step is not positive.
std::vector<Eigen::Vector3f> virtualViewpoints(const Eigen::Vector3f& centroid, const Eigen::Vector3f& axis,
                                               const Eigen::Vector3f& origin_a, const Eigen::Vector3f& origin_b,
                                               double step_rad);

/// Principal-axis planner. Object frame (Eq. 3.3 made right-handed): origin at the centroid,
/// Y = principal axis (pointing against gravity when it is not horizontal), Z = the line of
/// sight toward the sensor made perpendicular to Y, X = Y x Z (the thesis's X is
/// O_cP_s x O_cP_p = -X here; flipping it keeps the frame right-handed and changes no
/// metric). Grasps approach along -Z (from the sensor side) and close along X.
/// Metrics: force_balance_rad = |atan k_left| + |atan k_right| with each side fitted as
/// x = k y + b (Eq. 3.5 with the axes swapped so the vertical sides of a box give k = 0);
/// for the symmetric tapers of the thesis's objects this is the angle between the two side
/// lines, and it also penalises parallel sides that lean against the closing direction.
/// xoz_offset_m = |Z1 - Z2| of Eq. 3.10 over the contact regions of Eq. 3.9.
/// Single view: candidates pass the XOY threshold and then the XOZ threshold; they are
/// ranked by XOY angle (the thesis's step 6). next_view, the sensor pose rotated about the
/// principal axis (Eq. 3.6), is set when another view can resolve the failure: all XOY-stable
/// candidates fail XOZ (beta of Ch3.2.3); no graspable zone because the seen flat face is
/// wider than the opening (look along it, beta = alpha); the table stops the hand at every
/// stable grasp (look from above). principal_axis_next_view.h computes each of these views.
/// Two cameras: the best XOY candidate of each virtual viewpoint, ranked by XOZ offset
/// (Eqs. 3.9-3.10); `candidates` holds one entry per virtual viewpoint that had one.
/// plan() is const and thread-safe.
class PrincipalAxisGraspPlanner : public GraspPlanner
{
public:
  explicit PrincipalAxisGraspPlanner(PrincipalAxisParams params = {}) : params_(params) {}
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return "principal_axis"; }
  const PrincipalAxisParams& params() const { return params_; }

private:
  PrincipalAxisParams params_;
};

}  // namespace fast_grasp
