// The fused planner (thesis 7.3 A and B, "combine the algorithms"): runs the thesis planners on
// one view, pools their candidates with two simple families of its own (top-down and side
// grasps through the object's centroid), fits the real hand at each (GripperVolumeCheck, with
// the table tilt), and ranks the pool with one success model (grasp_features.h) whose
// coefficients were fitted to the physics evaluator's outcomes on the training objects
// (config/grasp_planners.yaml `fused/model`, written by scripts/fit_fused_model.py).
//
// Beyond the thesis: the thesis proposes fusing its planners but never built or measured it;
// the generated families are ours, added because the physics evaluator showed a plain top-down
// grasp holding more often than any thesis planner's top grasp. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/lying_cylinder.h"
#include "fast_grasp/grasping/near_range.h"
#include "fast_grasp/grasping/one_seen_face.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/unseen_part.h"
#include "fast_grasp/grasping/wide_flat_top.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
struct FusedParams
{
  /// Pool the grasps of these planners (principal_axis, cshape, boundary, concavity).
  std::vector<std::string> planners{ "principal_axis", "cshape", "boundary", "concavity" };
  /// Top-down candidates, one per closing direction over 180 deg, at the centroid and at +-1/4 of
  /// the object's length along its major horizontal axis (0 = none); each closes on what lies
  /// between the fingers, the palm palm_clearance_m above the highest point under it.
  std::size_t top_down_directions = 12;
  /// Side candidates at the centroid's height, approaching horizontally from the camera's side
  /// within +-side_spread_rad of the view direction (0 = none).
  std::size_t side_directions = 5;
  double side_spread_rad = 0.8;
  /// Tall objects (at least tall_object_min_height_m high; 0 = none): side candidates also
  /// close at these fractions of the height, each as wide as the seen points in a finger-wide
  /// band there (a bottle's shoulder or neck), and pooled side grasps (approach within 30 deg
  /// of horizontal) closing below tall_side_min_height_frac of the height rank after every
  /// other candidate. Beyond the thesis: a horizontal closing line below the centre of mass
  /// holds the object as an inverted pendulum. In physics (clutter training pool, session 18)
  /// tall objects' side grasps held 33-58 % closing at 0.2-0.5 of the height, 73 % at 0.6,
  /// 85 % at 0.7 and every time at 0.9 and above.
  double tall_object_min_height_m = 0.0;
  std::vector<double> side_high_fracs;
  double tall_side_min_height_frac = 0.6;
  /// A round object lying on the table (lying_cylinder.h): pooled grasps closing across its
  /// axis whose fingertips fall short of it, or whose open hand on its way in would land on
  /// its hidden far side (openHandDepthInCylinder), rank after every other candidate (kept as
  /// a last resort, like the pendulum side grasps above).
  LyingCylinderParams lying_cylinder;
  /// A narrow grasp across one face seen from in front, its depth unseen (one_seen_face.h),
  /// ranks after every other candidate (shared with the thesis planners' hold check).
  OneSeenFaceParams one_seen_face;
  /// A grasp closing where the camera's near limit cut the object (near_range.h,
  /// closesOnNearLimitCut) ranks after every other candidate. Not a fused/ key: makeGraspPlanner
  /// copies the top-level near_range section here (one camera, shared with the hold check).
  NearRangeParams near_range;
  /// End-on candidates: approach horizontally along the footprint's major axis from each end,
  /// the palm palm_clearance_m before the end, closing across what the fingers surround at the
  /// centroid's height. Beyond the thesis: a round object lying down (a can, a bottle) longer
  /// than the opening can only be closed on from above, where a finger_depth_m-long finger
  /// ends near its equator and it slips out on the lift; from its end the fingers close
  /// across its diameter. The hand is checked without the unseen part (its far finger passes
  /// the hidden side; its palm still keeps out of it, palmEntersUnseen): the width assumes the
  /// object as wide as high there.
  bool end_grasps = true;
  /// The pooled planners, the generated candidates and the features see at most this many
  /// points (every k-th point of a larger view; 0 = all). The planners' cost grows with the
  /// points (C-shape ~21 ms at 10k) while a 5 mm voxel-filtered object at 0.6 m has a few
  /// hundred to two thousand points: the cap only bites on dense clouds.
  std::size_t max_pooled_points = 2000;
  /// Each pooled planner grasp is also offered pushed deeper along its approach, up to this far
  /// in 5 mm steps, the deepest pose the hand check (gripper_fit) passes (0 = never). Beyond the
  /// thesis: its planners put the closing line where they found the contacts, often the top
  /// of a round object lying down, and in physics a hand whose fingertips end above the
  /// equator lets it slip out on the lift. Both poses are pooled; the model ranks them.
  double deepen_pooled_max_m = 0.0;
  /// Inside the pool, these planners stop after this many grasps instead of their own
  /// max_grasps (planner name -> count; the planners' sections stay as they are for standalone
  /// use). The C-shape planner's search ends after max_grasps grasps pass, and it is most of
  /// the fused planner's time: 5 instead of 10 cut 24.5 -> 19.6 ms at 10k points with the same
  /// physics outcome in all 99 training trials.
  std::map<std::string, std::size_t> pooled_max_grasps;
  /// Beyond the thesis: a body lying along the table that is wider than the hand's opening once
  /// its hidden far side is completed by mirror symmetry (unseen_part.h, completeByMirror) gets
  /// no grasp (NoStableGrasp, saying so). Nothing closes across its middle, and what the pool
  /// offers instead (its cap, an end, a finger on the hidden side) drops it: in the clutter
  /// training piles a bleach bottle lying on its broad face (9.8 cm, seen 7.5-8 cm) held 2 of
  /// its 11 attempts and was 9 of the 28 failed grasps. Refused when the completed width
  /// exceeds max_opening_m by more than min_excess_over_opening_m.
  struct WideLyingBody
  {
    bool enabled = false;
    MirrorCompletionParams mirror;
    double min_excess_over_opening_m = 0.0;
  } wide_lying_body;
  /// Beyond the thesis: a body whose top is one flat face wider than the hand's opening in every
  /// direction (a cereal box lying flat) gets no grasp (NoStableGrasp, saying so): wide_flat_top.h.
  WideFlatTopParams wide_flat_top;
  /// Grasps returned (best first) and the success probability a grasp needs to be returned.
  std::size_t max_grasps = 10;
  double min_success_probability = 0.0;
  /// The hand check of the generated candidates (the planners' own use their sections'). Its
  /// finger_graze_margin_m is applied to the grasps returned only: one whose open finger has a
  /// seen or unseen point that close ranks as if the model gave it finger_graze_penalty less.
  /// Beyond the thesis: in physics such a finger brushed the object on the approach. Off in the
  /// shipped config (margin 0): it traded lifts for fewer touches (docs/evaluation.md).
  GripperFitParams gripper_fit;
  double finger_graze_penalty = 0.0;
  /// Grasps with a drop risk (dropRisk(): below a tall object's centre of mass, short of a
  /// lying cylinder's axis, onto its hidden side, across one seen face, on the near limit's cut)
  /// rank after every grasp without one; true returns them there, false never (the object then
  /// gets NoStableGrasp when no other grasp remains, saying why, with a next view where one
  /// helps). Beyond the thesis: in physics the fused planner's top grasp held 1 of 10 times when
  /// all its candidates carried a risk. The shipped file says false for one object and true for
  /// a table's planner (tablePlannerConfig, grasp_planner_params.h).
  bool return_drop_risk_grasps = true;
  GraspSuccessModel model;

  /// The top-level keys of config/grasp_planners.yaml (loadGraspPlannerConfig, the nodelets).
  PlannerInputLimits input_limits;

  std::string validate() const;
};

class FusedGraspPlanner : public GraspPlanner
{
public:
  /// `planners`: the pooled planners, already built with their own parameters.
  FusedGraspPlanner(std::vector<std::unique_ptr<GraspPlanner>> planners, FusedParams params);
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return "fused"; }
  const FusedParams& params() const { return params_; }

private:
  std::vector<std::unique_ptr<GraspPlanner>> planners_;
  FusedParams params_;
};

}  // namespace fast_grasp
