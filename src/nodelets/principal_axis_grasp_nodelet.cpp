// fast_grasp/PrincipalAxisGrasp: thesis Ch3 planner (one or two cameras) behind the shared
// grasp-planner wrapper, plus ~next_view (Ch3.2.3) when no grasp passes.
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"
#include "fast_grasp/principal_axis_grasp.h"

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
    ros::NodeHandle nh(private_nh, "principal_axis");
    PrincipalAxisParams p;
    nh.param("sweep_step_m", p.sweep_step_m, p.sweep_step_m);
    nh.param("grid_cell_m", p.grid_cell_m, p.grid_cell_m);
    nh.param("gap_close_rows", p.gap_close_rows, p.gap_close_rows);
    nh.param("side_depth_m", p.side_depth_m, p.side_depth_m);
    nh.param("force_balance_max_rad", p.force_balance_max_rad, p.force_balance_max_rad);
    nh.param("xoz_max_offset_m", p.xoz_max_offset_m, p.xoz_max_offset_m);
    nh.param("min_axis_view_angle_rad", p.min_axis_view_angle_rad, p.min_axis_view_angle_rad);
    nh.param("min_thickness_m", p.min_thickness_m, p.min_thickness_m);
    int min_points = static_cast<int>(p.min_points);
    nh.param("min_points", min_points, min_points);
    p.min_points = static_cast<std::size_t>(std::max(1, min_points));
    nh.param("two_camera_mode", p.two_camera_mode, p.two_camera_mode);
    nh.param("virtual_view_step_rad", p.virtual_view_step_rad, p.virtual_view_step_rad);
    int max_grasps = static_cast<int>(p.max_grasps);
    nh.param("max_grasps", max_grasps, max_grasps);
    p.max_grasps = static_cast<std::size_t>(std::max(1, max_grasps));
    next_view_pub_ = private_nh.advertise<geometry_msgs::PoseStamped>("next_view", 2, /*latch=*/true);
    return std::make_unique<PrincipalAxisGraspPlanner>(p);
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
