// fast_grasp/BoundaryGrasp: thesis Ch4 boundary (caging) planner behind the shared grasp-planner wrapper.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class BoundaryGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~boundary/* and the sections it shares (config/grasp_planners.yaml); throws naming a bad key.
    return makeGraspPlanner("boundary", plannerConfig(private_nh));
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::BoundaryGraspNodelet, nodelet::Nodelet)
