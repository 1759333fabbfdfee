#include "bag_frames.h"

#include <pcl_conversions/pcl_conversions.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <stdexcept>

namespace fast_grasp
{
std::vector<BagFrame> readBagFrames(const std::string& bag_path, const std::string& cloud_topic,
                                    const std::string& base_frame)
{
  rosbag::Bag bag;
  try
  {
    bag.open(bag_path, rosbag::bagmode::Read);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error("cannot open bag '" + bag_path + "': " + e.what());
  }
  tf2::BufferCore transforms;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf_static")))
  {
    const auto tf = m.instantiate<tf2_msgs::TFMessage>();
    if (tf)
      for (const auto& t : tf->transforms)
        transforms.setTransform(t, "bag", /*is_static=*/true);
  }
  std::vector<BagFrame> frames;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(cloud_topic)))
  {
    const auto msg = m.instantiate<sensor_msgs::PointCloud2>();
    if (!msg)
      continue;
    BagFrame frame;
    frame.stamp_s = msg->header.stamp.toSec();
    frame.frame_id = msg->header.frame_id;
    frame.cloud.reset(new pcl::PointCloud<pcl::PointXYZRGB>);
    pcl::fromROSMsg(*msg, *frame.cloud);
    try
    {
      frame.camera_to_base = tf2::transformToEigen(transforms.lookupTransform(base_frame, msg->header.frame_id, ros::Time(0)))
                                 .cast<float>();
    }
    catch (const tf2::TransformException& e)
    {
      throw std::runtime_error("bag '" + bag_path + "': no static transform " + base_frame + " <- " +
                               msg->header.frame_id + ": " + e.what());
    }
    frames.push_back(std::move(frame));
  }
  if (frames.empty())
    throw std::runtime_error("bag '" + bag_path + "' has no message on " + cloud_topic);
  return frames;
}

bool bagHasTopic(const std::string& bag_path, const std::string& topic)
{
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  for (const rosbag::ConnectionInfo* connection : view.getConnections())
    if (connection->topic == topic)
      return true;
  return false;
}

const BagFrame& closestFrame(const std::vector<BagFrame>& frames, double stamp_s)
{
  if (frames.empty())
    throw std::runtime_error("no frame to choose from");
  const BagFrame* closest = &frames.front();
  for (const BagFrame& candidate : frames)
    if (std::abs(candidate.stamp_s - stamp_s) < std::abs(closest->stamp_s - stamp_s))
      closest = &candidate;
  return *closest;
}

}  // namespace fast_grasp
