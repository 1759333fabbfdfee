// fast_grasp/CShapeGrasp: thesis Ch6 C-shape planner behind the shared grasp-planner wrapper.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class CShapeGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    // ~cshape/* and the sections it shares (config/grasp_planners.yaml); throws naming a bad key.
    return makeGraspPlanner("cshape", plannerConfig(private_nh));
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::CShapeGraspNodelet, nodelet::Nodelet)
