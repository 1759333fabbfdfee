// Reads camera frames and their static camera pose out of a bag, for the offline tools
// and benchmarks (not used by the nodelets, which get both from topics and tf).
#pragma once

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <string>
#include <vector>

namespace fast_grasp
{
struct BagFrame
{
  double stamp_s = 0.0;
  std::string frame_id;
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud;  // organised, as recorded
  Eigen::Isometry3f camera_to_base = Eigen::Isometry3f::Identity();
};

/// All messages on `cloud_topic`, each with the pose of its frame in `base_frame` taken
/// from the bag's /tf_static. Throws std::runtime_error with a readable reason on an
/// unreadable bag, a missing topic or a frame with no static path to `base_frame`.
std::vector<BagFrame> readBagFrames(const std::string& bag_path, const std::string& cloud_topic,
                                    const std::string& base_frame = "base_link");

/// The frame of `frames` closest in time to `stamp_s` (two-camera mode: the head camera's frame
/// for a hand camera's). Throws std::runtime_error when `frames` is empty.
const BagFrame& closestFrame(const std::vector<BagFrame>& frames, double stamp_s);

/// True when the bag records `topic` (e.g. a head camera next to the hand camera). Throws
/// rosbag::BagException on an unreadable bag.
bool bagHasTopic(const std::string& bag_path, const std::string& topic);

}  // namespace fast_grasp
