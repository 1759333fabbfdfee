// Fast C-shape grasp planner for unknown objects, thesis Chapter 6.2 (steps 2-8).
// The gripper is modelled as the C-shape of Eq. 6.1; C-shapes approach along the (down-
// sampled) surface normals, are rotated about the normal in steps of delta starting from the
// local principal axis (Fig. 6.8), pushed in by the rule of Eq. 6.9, checked for collision
// with the object and its unseen part (Eq. 6.8), and ranked by the local-geometry variance
// and the force balance sigma = |atan k1| + |atan k2| (step 8). Beyond the thesis: the
// gripper body (C + hand box behind it) must keep a clearance above the view's table plane,
// the depth is limited so it does, and approaches from above get a small score bonus.
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

namespace fast_grasp
{
struct CShapeParams
{
  /// delta of Fig. 6.7: rotation step of the C-shape about the normal. The C is symmetric
  /// under a half turn, so ceil(pi / delta) orientations are tried per normal.
  double angle_increment_rad = M_PI / 12.0;
  /// Step 3: voxel size of the normal down-sampling (one normal per voxel, taken from the
  /// input point nearest to the voxel centroid).
  double normal_downsample_radius_m = 0.01;
  /// Voxel size of the coarse obstacle points every orientation is screened against (the
  /// survivors are re-checked at full resolution); 0 = min(r2 - r1, w) / 3 in [1, 5] mm.
  double obstacle_leaf_m = 0.0;
  /// Fig. 6.8: radius of the neighbourhood whose principal axis gives the first C-shape axis;
  /// 0 = the gripper's cshape_r1_m.
  double local_axis_radius_m = 0.0;
  /// Stop after this many normals gave a grasp (the best orientation of each normal is kept);
  /// the result holds them best first.
  int max_grasps = 10;
  /// Stop searching after this much wall time (the grasps found so far are returned).
  double time_budget_s = 0.1;
  /// Seed of the random normal order (step 8: "another random normal").
  std::uint32_t seed = 0;
  /// Step 7: largest allowed sum of the distances of the side points to their fitted lines.
  /// Side points are the extreme points of `side_bins` slices across the finger width, so the
  /// sum is over at most 2 * side_bins points and does not grow with the cloud density.
  /// The sum is over <= 16 points: depth noise alone (Nguyen's sigma_z ~1.3 mm at 0.6 m, mean
  /// absolute deviation ~1 mm per point) already gives ~0.016 m, so 0.02 left almost no room
  /// for real surface shape; 0.03 allows ~2 mm per point.
  double variance_threshold_m = 0.03;
  int side_bins = 8;
  /// A side needs points in at least this many slices to fit its line.
  int min_side_bins = 3;
  /// Step 8: largest accepted sigma (0 = both sides perpendicular to the closing direction).
  /// The thesis's text calls a larger sigma more stable, but sigma is the sides' angle to the
  /// C axis, so 0 means the finger forces are normal to both sides; smaller is better here,
  /// as DESIGN.md's force_balance_rad defines it.
  double force_balance_threshold_rad = 0.6;
  /// The C-shape is inflated by this much for every collision test (Eq. 6.1 volume grown
  /// by the clearance), so contacts grazing between sparse points still count.
  double collision_clearance_m = 0.003;
  /// Points within this distance of the extreme closing coordinate form a contact.
  double contact_tolerance_m = 0.0005;
  /// Where the grasp frame's origin (the C-shape centre) ends up along the approach.
  enum class DepthRule
  {
    /// Where the fingers meet the object's widest seen part: the deeper of the mean contact
    /// depth and the depth of the inscribed circle of the seen width (Eq. 6.9 with the
    /// object's half-width; exact for round sections whose widest part hides near the
    /// silhouette), never deeper than Eq. 6.9 allows; falls back to Eq. 6.9 if it collides.
    /// (Screening at the Eq. 6.9 placement first, as the thesis does, rejected ~90 % of the
    /// grasps on synthetic boxes and cylinders: the deep C's fingers reach the unseen part.)
    ContactDepth,
    /// The C-shape centre of Eq. 6.9 exactly (deepest placement: the object touches the
    /// inner back of the C; the thesis's enveloping grasp for under-actuated grippers).
    CShapeCentre
  };
  DepthRule depth_rule = DepthRule::ContactDepth;
  /// Eq. 6.8: treat the unseen part as part of the object. Disable only for debugging.
  bool use_unseen_part = true;
  UnseenPartParams unseen;
  /// When the view has a table plane, reject every configuration whose gripper body comes
  /// closer than table_clearance_m to the table (or goes below it). The body is the nominal
  /// C-shape of Eq. 6.1 plus the hand box behind it: palm_thickness_m deep along -approach
  /// behind the back of the C (depth -r2 - palm_thickness .. -r2 from the C centre), 2 r2
  /// along the closing direction and max(palm_width, w) across the C plane. Without
  /// it the planner returns low sideways C-shapes whose palm is inside the table, which the
  /// arm planner then rejects (octomap / palm link collision).
  bool check_table_clearance = true;
  double table_clearance_m = 0.01;
  /// Objects lower than the C's reach below its centre (a hammer handle, a pan's rim) cannot
  /// take the C centre at the normal's point without the fingertips entering the table. The C
  /// may then stop short, its centre in front of the point, as long as the point stays at
  /// least this far inside the mouth (behind the fingertips): a fingertip grasp. The same
  /// shallower placements (5 mm steps) are tried when only the unseen part blocks the
  /// preferred depth (the far finger behind a box's hidden back: the box is taken by its seen
  /// top edge). Negative = never (the thesis's placement only).
  double min_fingertip_overlap_m = 0.015;
  /// Score bonus from_above_weight * (approach . gravity): approaches from above (+) are
  /// easier for an arm standing on the same table, from below (-) harder. Small next to sigma,
  /// which stays the main criterion.
  double from_above_weight_rad = 0.05;
  /// Coarse-to-fine: orientations whose coarse (voxel-centroid) sides already exceed the
  /// variance or force-balance threshold by more than this factor are not re-checked at full
  /// resolution (stability only; collision is always re-checked at full resolution). On the
  /// bags ~90 % of the full-resolution checks failed on the variance; 0 disables the screen.
  double coarse_screen_factor = 2.0;
  /// Score = -(sigma + variance_weight * variance + torque_weight * torque offset); the
  /// weights only break ties between grasps of similar force balance.
  double variance_weight_rad_per_m = 1.0;
  double torque_weight_rad_per_m = 0.5;
  /// Also subtracted: unseen_width_weight * (width of seen + unseen points in the closing
  /// region - width of the seen points), i.e. how much of the grasp relies on the guess of
  /// the hidden side. Favours approaches facing the camera, where both sides are seen.
  double unseen_width_weight_rad_per_m = 5.0;
  /// Also subtracted: shallow_weight * how far the C stopped short of its preferred depth (a
  /// fingertip grasp holds less of the object than an enveloping one).
  double shallow_weight_rad_per_m = 5.0;
  /// Inputs with fewer finite points, or thinner than this (RMS distance from the best
  /// plane) or narrower (RMS distance from the best line), are DegenerateInput.
  std::size_t min_points = 10;
  double min_thickness_m = 2e-4;
  /// At most this many evaluated candidates are kept in GraspResult::candidates.
  std::size_t max_recorded_candidates = 200;
  /// Final check of each passing orientation with the real hand's volume (gripper_volume.h)
  /// against the seen points and the unseen part: the C of Eq. 6.1 has no flat palm, so a
  /// C that envelops the object deeply can put the palm into it. The palm is backed out
  /// when it can be; otherwise the next orientation is tried.
  GripperFitParams gripper_fit;

  /// The top-level keys of config/grasp_planners.yaml (loadGraspPlannerConfig, the nodelets).
  PlannerInputLimits input_limits;

  /// Empty when usable, else why not.
  std::string validate() const;
};

/// One placement of the C-shape: centre of its circles, approach (unit, from the hand into
/// the object) and closing direction (unit, perpendicular to the approach).
struct CShapePose
{
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  Eigen::Vector3f approach = Eigen::Vector3f::UnitX();
  Eigen::Vector3f closing = Eigen::Vector3f::UnitY();
};

/// True when `point` lies in the gripper volume C_c = C_out - C_in - C_red of Eq. 6.1:
/// |x| <= w/2 across the C plane, r1 <= distance from the centre in the C plane <= r2, and
/// not in the open mouth (|closing coordinate| <= r1 and in front of the centre).
/// `clearance_m` inflates the C (r1 - c, r2 + c, w/2 + c), as the planner's collision check.
bool insideCShape(const CShapePose& pose, const GripperModel& gripper, const Eigen::Vector3f& point,
                  double clearance_m = 0.0);

/// Number of points of `cloud` inside the C-shape at `pose` (brute force; for tests and
/// for checking other obstacle sets).
std::size_t countInsideCShape(const CShapePose& pose, const GripperModel& gripper, const CloudXYZ& cloud,
                              double clearance_m = 0.0);

class CShapeGraspPlanner : public GraspPlanner
{
public:
  explicit CShapeGraspPlanner(CShapeParams params = {});

  /// Grasps best first, or a typed failure. Thread-safe (const, no shared state).
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return "cshape"; }
  const CShapeParams& params() const { return params_; }

private:
  CShapeParams params_;
};

}  // namespace fast_grasp
