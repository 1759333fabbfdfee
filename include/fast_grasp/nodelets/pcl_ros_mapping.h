// Debian's pcl_ros (1.7.5) deserialises a pcl::PointCloud<T> with a field mapping held in a
// function-local static of Serializer<pcl::PointCloud<T>>::read: the first message fills it, and
// the emptiness check runs outside its mutex. Two manager worker threads deserialising their first
// clouds of one point type at once (CloudFusion's ~hand and ~head, the planners of one manager on
// a cloud from another process) built the mapping in one thread while the other read it
// (ThreadSanitizer, cloud_fusion.test; docs/tests.md), and each thread that saw it empty appended
// the mapping once more. Filling it once, before any subscriber exists, leaves only reads.
#pragma once

#include <pcl/point_types.h>
#include <pcl_ros/point_cloud.h>
#include <ros/serialization.h>

#include <cstdint>
#include <mutex>
#include <vector>

namespace fast_grasp
{
namespace detail
{
/// One point of PointT through roscpp serialisation and back: the mapping of PointT's own
/// fields (pcl::PointCloud<PointT>'s message layout) is built here.
template <typename PointT>
void primePclRosFieldMapping()
{
  pcl::PointCloud<PointT> cloud;
  cloud.push_back(PointT());
  std::vector<std::uint8_t> buffer(ros::serialization::serializationLength(cloud));
  ros::serialization::OStream out(buffer.data(), static_cast<std::uint32_t>(buffer.size()));
  ros::serialization::serialize(out, cloud);
  pcl::PointCloud<PointT> back;
  ros::serialization::IStream in(buffer.data(), static_cast<std::uint32_t>(buffer.size()));
  ros::serialization::deserialize(in, back);
}
}  // namespace detail

/// Every nodelet calls this first in onInit: builds pcl_ros's field mapping of each point type a
/// fast_grasp nodelet subscribes to, once per process. A publisher whose clouds of one of these
/// types carry other field offsets than pcl::PointCloud<T> itself would be read with this mapping;
/// before, with the mapping of whichever cloud of that type came first.
inline void primePclRosFieldMappings()
{
  static std::once_flag once;
  std::call_once(once, [] {
    detail::primePclRosFieldMapping<pcl::PointXYZ>();
    detail::primePclRosFieldMapping<pcl::PointXYZRGB>();
    detail::primePclRosFieldMapping<pcl::PointXYZL>();
    detail::primePclRosFieldMapping<pcl::PointNormal>();
  });
}

}  // namespace fast_grasp
