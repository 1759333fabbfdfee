// tf2 look-up with a wall-clock timeout.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <string>

namespace fast_grasp
{
/// Waits up to `timeout_s` of wall time for target <- source at `stamp`, then looks it up
/// (throwing tf2::TransformException with tf2's reason). tf2's own timeout sleeps in ROS
/// time, which never advances once a bag played with --clock has ended, so a cloud that
/// arrives just before its transform would hang the callback for good.
inline geometry_msgs::TransformStamped lookupTransformWallTimeout(const tf2_ros::Buffer& buffer,
                                                                  const std::string& target, const std::string& source,
                                                                  const ros::Time& stamp, double timeout_s)
{
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (!buffer.canTransform(target, source, stamp) && ros::WallTime::now() < give_up && ros::ok())
    ros::WallDuration(0.002).sleep();
  return buffer.lookupTransform(target, source, stamp);
}

}  // namespace fast_grasp
