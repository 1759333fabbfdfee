// Test helpers for the hold-check and fused-rule tests (test_lying_cylinder, test_wide_flat_top,
// ...): an analytic shape on the table seen from one camera, grasps placed by hand, a planner
// that returns them as a thesis planner would have, and the fused planner over them. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/grasping/fused_grasp.h"
#include "synthetic_views.h"

#include <memory>
#include <utility>
#include <vector>

namespace fast_grasp
{
namespace hold_check_fixtures
{
/// The camera both tests look from: up and to the side, 0.4 m from the table's origin.
inline const Eigen::Vector3d kCamera(-0.40, 0.12, 0.42);

/// `shapes` as that camera sees them (3 mm rays, `noise_m` of depth noise, seed 7), as one
/// object on the table z = 0 (several shapes: one cluster of touching objects).
inline ObjectView tableView(const std::vector<synthetic::Shape>& shapes, double noise_m = 0.0)
{
  auto cloud = synthetic::renderView(shapes, { kCamera, 0.003, noise_m, 7 });
  ObjectView view = synthetic::makeObjectView(cloud, kCamera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  return view;
}

/// One `shape` as that camera sees it, on the table z = 0.
inline ObjectView tableView(const synthetic::Shape& shape, double noise_m = 0.0)
{
  return tableView(std::vector<synthetic::Shape>{ shape }, noise_m);
}

/// A grasp centred at `centre`, approaching along `approach`, closing along `closing`.
inline GraspCandidate graspAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& approach,
                              const Eigen::Vector3d& closing, double score = 0.0)
{
  GraspCandidate grasp;
  grasp.pose = makeGraspPose(centre, approach, closing);
  grasp.width_m = 0.07;
  grasp.score = score;
  return grasp;
}

/// A planner that returns what it was given: the grasps a thesis planner would have returned.
class GivenGrasps : public GraspPlanner
{
public:
  explicit GivenGrasps(GraspResult result) : result_(std::move(result)) {}
  GraspResult plan(const ObjectView&, const GripperModel&) const override { return result_; }
  const char* name() const override { return "concavity"; }

private:
  GraspResult result_;
};

/// The fused planner over `given` alone: no top-down, side or end candidates of its own, every
/// point seen, no deeper copies. With no model weights its grasps keep their order unless a
/// rule of fused's ranks one last or refuses the object; `adjust` sets the rule under test.
template <typename Adjust>
GraspResult fusedOverGivenGrasps(const GraspResult& given, const ObjectView& view, const GripperModel& gripper,
                                 Adjust adjust)
{
  FusedParams fused;
  fused.top_down_directions = 0;
  fused.side_directions = 0;
  fused.end_grasps = false;
  fused.max_pooled_points = 0;
  fused.deepen_pooled_max_m = 0.0;
  adjust(fused);
  std::vector<std::unique_ptr<GraspPlanner>> pooled;
  pooled.push_back(std::make_unique<GivenGrasps>(given));
  return FusedGraspPlanner(std::move(pooled), fused).plan(view, gripper);
}

}  // namespace hold_check_fixtures
}  // namespace fast_grasp
