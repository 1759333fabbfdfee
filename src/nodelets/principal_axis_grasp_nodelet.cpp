// fast_grasp/PrincipalAxisGrasp: thesis Ch3 planner (one or two cameras) behind the shared
// grasp-planner wrapper, which also publishes ~next_view (Ch3.2.3) when no grasp passes.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"
#include "fast_grasp/grasping/principal_axis_grasp.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class PrincipalAxisGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~principal_axis/* (config/grasp_planners.yaml); throws naming a bad key.
    PrincipalAxisParams params = principalAxisParamsFromYaml(paramAsYaml(private_nh, "principal_axis"));
    params.input_limits = inputLimits(private_nh);
    return std::make_unique<PrincipalAxisGraspPlanner>(params);
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::PrincipalAxisGraspNodelet, nodelet::Nodelet)
