// Input validation shared by every stage: one reason per failure, never an exception.
#pragma once

#include <pcl/point_cloud.h>

#include <cstddef>
#include <string>

namespace fast_grasp
{
struct CloudCheck
{
  bool ok = true;
  std::string reason;  // empty when ok
  std::size_t finite_points = 0;
};

/// Checks a cloud before processing: null, empty, more than `max_points`, no finite point.
/// Points with a NaN or infinite coordinate count as missing (organised clouds keep them).
template <typename PointT>
CloudCheck checkCloud(const typename pcl::PointCloud<PointT>::ConstPtr& cloud, std::size_t max_points);

}  // namespace fast_grasp
