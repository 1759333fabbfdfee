#include "fast_grasp/perception/cloud_checks.h"

#include <pcl/point_types.h>

#include <cmath>
#include <sstream>

namespace fast_grasp
{
template <typename PointT>
CloudCheck checkCloud(const typename pcl::PointCloud<PointT>::ConstPtr& cloud, std::size_t max_points)
{
  CloudCheck check;
  auto fail = [&](const std::string& reason) {
    check.ok = false;
    check.reason = reason;
    return check;
  };
  if (!cloud)
    return fail("null cloud");
  if (cloud->points.empty())
    return fail("empty cloud (0 points)");
  if (cloud->width * cloud->height != cloud->points.size())
  {
    std::ostringstream why;
    why << "malformed cloud: width*height = " << cloud->width * cloud->height << " but " << cloud->points.size()
        << " points";
    return fail(why.str());
  }
  if (cloud->points.size() > max_points)
  {
    std::ostringstream why;
    why << "cloud too large: " << cloud->points.size() << " points exceeds max_input_points " << max_points;
    return fail(why.str());
  }
  std::size_t infinite = 0;
  for (const auto& p : cloud->points)
  {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      ++check.finite_points;
    else if (std::isinf(p.x) || std::isinf(p.y) || std::isinf(p.z))
      ++infinite;
  }
  if (check.finite_points == 0)
  {
    std::ostringstream why;
    why << "no finite point among " << cloud->points.size() << " (" << infinite << " infinite, "
        << cloud->points.size() - infinite << " NaN)";
    return fail(why.str());
  }
  return check;
}

template CloudCheck checkCloud<pcl::PointXYZ>(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr&, std::size_t);
template CloudCheck checkCloud<pcl::PointXYZRGB>(const pcl::PointCloud<pcl::PointXYZRGB>::ConstPtr&, std::size_t);
template CloudCheck checkCloud<pcl::PointNormal>(const pcl::PointCloud<pcl::PointNormal>::ConstPtr&, std::size_t);
template CloudCheck checkCloud<pcl::PointXYZL>(const pcl::PointCloud<pcl::PointXYZL>::ConstPtr&, std::size_t);

}  // namespace fast_grasp
