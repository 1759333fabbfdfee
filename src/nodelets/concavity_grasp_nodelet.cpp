// fast_grasp/ConcavityGrasp: thesis Ch5 concavity planner behind the shared grasp-planner wrapper.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class ConcavityGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~concavity/* and the sections it shares (config/grasp_planners.yaml); throws naming a bad key.
    return makeGraspPlanner("concavity", plannerConfig(private_nh));
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::ConcavityGraspNodelet, nodelet::Nodelet)
