// fast_grasp/PrincipalAxisGrasp: thesis Ch3 planner (one or two cameras) behind the shared
// grasp-planner wrapper, plus ~next_view (Ch3.2.3) when no grasp passes.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"
#include "fast_grasp/grasping/principal_axis_grasp.h"

#include <geometry_msgs/PoseStamped.h>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_eigen/tf2_eigen.h>

namespace fast_grasp
{
class PrincipalAxisGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    next_view_pub_ = private_nh.advertise<geometry_msgs::PoseStamped>("next_view", 2, /*latch=*/true);
    // ~principal_axis/* (config/grasp_planners.yaml); throws naming a bad key.
    return std::make_unique<PrincipalAxisGraspPlanner>(
        principalAxisParamsFromYaml(paramAsYaml(private_nh, "principal_axis")));
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

PLUGINLIB_EXPORT_CLASS(fast_grasp::PrincipalAxisGraspNodelet, nodelet::Nodelet)
