// Test helper for the hold-check tests (test_lying_cylinder, test_resting_ball): an analytic
// shape on the table seen from one camera, grasps placed by hand, and a planner that returns
// them as a thesis planner would have. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "synthetic_views.h"

#include <utility>

namespace fast_grasp
{
namespace hold_check_fixtures
{
/// The camera both tests look from: up and to the side, 0.4 m from the table's origin.
inline const Eigen::Vector3d kCamera(-0.40, 0.12, 0.42);

/// `shape` as that camera sees it (3 mm rays, `noise_m` of depth noise, seed 7), on the table z = 0.
inline ObjectView tableView(const synthetic::Shape& shape, double noise_m = 0.0)
{
  auto cloud = synthetic::renderView(shape, { kCamera, 0.003, noise_m, 7 });
  ObjectView view = synthetic::makeObjectView(cloud, kCamera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  return view;
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

}  // namespace hold_check_fixtures
}  // namespace fast_grasp
