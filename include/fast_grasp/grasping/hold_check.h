// A thesis planner whose grasps on a lying round object are checked against the fit of that
// object (lying_cylinder.h) before they are returned: a grasp whose fingertips stop short of the
// axis, or whose open hand lands on the object's hidden side, is dropped, and when none is
// left the planner says why.
//
// Beyond the thesis. Its planners put the closing line where they saw contacts, the top and
// the camera-facing side of a can or bottle lying down; in physics such grasps hold half the
// time (lying_cylinder.h). The fused planner ranks them last and still has its own end-on
// and top-down grasps to offer; a single thesis planner has nothing better, and returning a
// grasp that will drop the object is worse than returning none (the arm does not try, the
// pipeline can take the next view). Measured on the training half (session 22, docs/evaluation.md).
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/lying_cylinder.h"

#include <memory>
#include <string>

namespace fast_grasp
{
struct HoldCheckParams
{
  /// The fit and its two tests (config/grasp_planners.yaml: fused/lying_cylinder, shared with
  /// the fused planner so that both judge the same grasp alike). Not enabled: nothing dropped.
  LyingCylinderParams lying_cylinder;
  /// How wide the hand is open on its way in (0 = the gripper's max_opening_m).
  double approach_opening_m = 0.0;
};

/// Wraps `planner`: same name, same grasps in the same order, less those the check drops.
class HoldCheckedPlanner : public GraspPlanner
{
public:
  HoldCheckedPlanner(std::unique_ptr<GraspPlanner> planner, HoldCheckParams params);
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return planner_->name(); }

private:
  std::unique_ptr<GraspPlanner> planner_;
  HoldCheckParams params_;
};

}  // namespace fast_grasp
