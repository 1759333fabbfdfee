// fast_grasp/PrincipalAxisGrasp: thesis Ch3 planner (one or two cameras) behind the shared
// grasp-planner wrapper, which also publishes ~next_view (Ch3.2.3) when no grasp passes.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class PrincipalAxisGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~principal_axis/* and the sections it shares (config/grasp_planners.yaml); throws naming a bad key.
    return makeGraspPlanner("principal_axis", plannerConfig(private_nh));
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::PrincipalAxisGraspNodelet, nodelet::Nodelet)
