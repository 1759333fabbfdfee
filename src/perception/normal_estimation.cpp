#include "fast_grasp/perception/normal_estimation.h"

#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <sstream>

namespace fast_grasp
{
NormalResult estimateNormals(const CloudXYZ::ConstPtr& object, const Eigen::Vector3f& viewpoint,
                             const NormalParams& params)
{
  NormalResult result;
  result.cloud = std::make_shared<CloudNormal>();
  auto fail = [&result](const std::string& why) {
    result.ok = false;
    result.reason = why;
    return result;
  };
  if (params.k_neighbours < 3)
    return fail("invalid parameters: k_neighbours must be >= 3");
  if (!viewpoint.allFinite())
    return fail("viewpoint is not finite");
  if (!object || object->empty())
    return fail("empty cloud (0 points)");
  const std::size_t needed = static_cast<std::size_t>(std::max(params.min_points, params.k_neighbours));
  if (object->size() < needed)
  {
    std::ostringstream why;
    why << "degenerate input: " << object->size() << " points, need at least " << needed;
    return fail(why.str());
  }
  for (const auto& p : object->points)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return fail("cloud holds non-finite points (expected a preprocessed cloud)");

  pcl::PointCloud<pcl::Normal> normals;
  pcl::NormalEstimationOMP<PointXYZ, pcl::Normal> estimator(params.threads == 0 ? 1 : params.threads);
  estimator.setInputCloud(object);
  estimator.setSearchMethod(std::make_shared<pcl::search::KdTree<PointXYZ>>());
  estimator.setKSearch(params.k_neighbours);
  // PCL flips each normal so that n . (viewpoint - p) >= 0 (Eq. of Ch6 step 2).
  estimator.setViewPoint(viewpoint.x(), viewpoint.y(), viewpoint.z());
  estimator.compute(normals);

  CloudNormal& out = *result.cloud;
  out.header = object->header;
  out.sensor_origin_ = Eigen::Vector4f(viewpoint.x(), viewpoint.y(), viewpoint.z(), 0.0f);
  out.sensor_orientation_ = object->sensor_orientation_;
  out.reserve(object->size());
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < object->size(); ++i)
  {
    const pcl::Normal& n = normals.points[i];
    if (!std::isfinite(n.normal_x) || !std::isfinite(n.normal_y) || !std::isfinite(n.normal_z))
    {
      ++dropped;  // collinear or duplicate neighbourhood: no plane to fit
      continue;
    }
    PointNormal p;
    p.getVector3fMap() = object->points[i].getVector3fMap();
    p.getNormalVector3fMap() = n.getNormalVector3fMap();
    p.curvature = n.curvature;
    out.push_back(p);
  }
  out.width = static_cast<std::uint32_t>(out.size());
  out.height = 1;
  out.is_dense = true;
  if (out.size() < needed)
  {
    std::ostringstream why;
    why << "degenerate input: only " << out.size() << " of " << object->size()
        << " points have a defined normal (collinear or coincident points)";
    return fail(why.str());
  }
  result.ok = true;
  if (dropped > 0)
  {
    std::ostringstream note;
    note << dropped << " points without a defined normal dropped";
    result.reason = note.str();
  }
  return result;
}

CloudNormal::Ptr downsampleNormals(const CloudNormal& normals, double radius_m)
{
  auto out = std::make_shared<CloudNormal>();
  out->header = normals.header;
  out->sensor_origin_ = normals.sensor_origin_;
  out->sensor_orientation_ = normals.sensor_orientation_;
  if (normals.empty() || !(radius_m > 0.0) || !std::isfinite(radius_m))
  {
    if (!normals.empty())
      *out = normals;
    return out;
  }
  // Omega -> Omega_d: voxel centroids of the points (positions only).
  auto positions = std::make_shared<CloudXYZ>();
  pcl::copyPointCloud(normals, *positions);
  CloudXYZ sparse;
  pcl::VoxelGrid<PointXYZ> voxel_grid;
  voxel_grid.setInputCloud(positions);
  const float leaf = static_cast<float>(radius_m);
  voxel_grid.setLeafSize(leaf, leaf, leaf);
  voxel_grid.filter(sparse);
  // Each P_di looks up its nearest P_i in Omega and takes P_i with its dense normal n_i.
  pcl::KdTreeFLANN<PointXYZ> tree;
  tree.setInputCloud(positions);
  std::vector<bool> taken(normals.size(), false);
  pcl::Indices nearest(1);
  std::vector<float> distance_sq(1);
  out->reserve(sparse.size());
  for (const auto& p : sparse.points)
  {
    if (tree.nearestKSearch(p, 1, nearest, distance_sq) < 1 || taken[nearest[0]])
      continue;
    taken[nearest[0]] = true;
    out->push_back(normals.points[nearest[0]]);
  }
  out->width = static_cast<std::uint32_t>(out->size());
  out->height = 1;
  out->is_dense = normals.is_dense;
  return out;
}

}  // namespace fast_grasp
