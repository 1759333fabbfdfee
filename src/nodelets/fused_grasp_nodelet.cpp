// fast_grasp/FusedGrasp: the fused planner (grasping/fused_grasp.h) behind the shared
// grasp-planner wrapper: every thesis planner's section plus ~fused/* (with the fitted success
// model) from config/grasp_planners.yaml; the shared wrapper publishes ~next_view when the
// pooled principal-axis planner suggests one and nothing in the pool fits.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class FusedGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // Each section read as the single-planner nodelets read it; throws naming a bad key.
    GraspPlannerConfig config;
    config.principal_axis = principalAxisParamsFromYaml(paramAsYaml(private_nh, "principal_axis"));
    config.cshape = cshapeParamsFromYaml(paramAsYaml(private_nh, "cshape"));
    config.boundary = boundaryParamsFromYaml(paramAsYaml(private_nh, "boundary"));
    config.concavity = concavityParamsFromYaml(paramAsYaml(private_nh, "concavity"));
    config.fused = fusedParamsFromYaml(paramAsYaml(private_nh, "fused"));
    setInputLimits(config, inputLimits(private_nh));
    return makeGraspPlanner("fused", config);
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::FusedGraspNodelet, nodelet::Nodelet)
