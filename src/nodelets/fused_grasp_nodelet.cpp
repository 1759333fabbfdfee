// fast_grasp/FusedGrasp: the fused planner (grasping/fused_grasp.h) behind the shared
// grasp-planner wrapper: every thesis planner's section plus ~fused/* (with the fitted success
// model) from config/grasp_planners.yaml; ~next_view when the pooled principal-axis planner
// suggests one and nothing in the pool fits.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"

#include <geometry_msgs/PoseStamped.h>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_eigen/tf2_eigen.h>

namespace fast_grasp
{
class FusedGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    next_view_pub_ = private_nh.advertise<geometry_msgs::PoseStamped>("next_view", 2, /*latch=*/true);
    // Each section read as the single-planner nodelets read it; throws naming a bad key.
    GraspPlannerConfig config;
    config.principal_axis = principalAxisParamsFromYaml(paramAsYaml(private_nh, "principal_axis"));
    config.cshape = cshapeParamsFromYaml(paramAsYaml(private_nh, "cshape"));
    config.boundary = boundaryParamsFromYaml(paramAsYaml(private_nh, "boundary"));
    config.concavity = concavityParamsFromYaml(paramAsYaml(private_nh, "concavity"));
    config.fused = fusedParamsFromYaml(paramAsYaml(private_nh, "fused"));
    return makeGraspPlanner("fused", config);
  }

  void publishExtras(const GraspResult& result, const std_msgs::Header& header) override
  {
    if (!result.next_view)
      return;
    geometry_msgs::PoseStamped pose;
    pose.header = header;
    pose.pose = tf2::toMsg(*result.next_view);
    next_view_pub_.publish(pose);
  }

private:
  ros::Publisher next_view_pub_;
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::FusedGraspNodelet, nodelet::Nodelet)
