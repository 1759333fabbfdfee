// fast_grasp/CShapeGrasp: thesis Ch6 C-shape planner behind the shared grasp-planner wrapper.
#include "fast_grasp/grasping/cshape_grasp.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class CShapeGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~cshape/* (config/grasp_planners.yaml); throws naming a bad key or value.
    CShapeParams params = cshapeParamsFromYaml(paramAsYaml(private_nh, "cshape"));
    params.input_limits = inputLimits(private_nh);
    return std::make_unique<CShapeGraspPlanner>(params);
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::CShapeGraspNodelet, nodelet::Nodelet)
