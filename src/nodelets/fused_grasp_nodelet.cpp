// fast_grasp/FusedGrasp: the fused planner (grasping/fused_grasp.h) behind the shared
// grasp-planner wrapper: every thesis planner's section plus ~fused/* (with the fitted success
// model) from config/grasp_planners.yaml; the shared wrapper publishes ~next_view when the
// pooled principal-axis planner suggests one and nothing in the pool fits.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class FusedGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~fused/* and the sections it shares (config/grasp_planners.yaml); throws naming a bad key.
    return makeGraspPlanner("fused", plannerConfig(private_nh));
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::FusedGraspNodelet, nodelet::Nodelet)
