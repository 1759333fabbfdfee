#include "fast_grasp/perception/container_join.h"

#include "fast_grasp/perception/cluster_groups.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

namespace fast_grasp
{
namespace
{
/// The cluster's extent along `axis` (unit, horizontal): lowest and highest coordinate.
std::pair<float, float> extentAlong(const ClusterFootprint& footprint, const Eigen::Vector2f& axis)
{
  float low = std::numeric_limits<float>::infinity(), high = -low;
  for (const auto& q : footprint.points)
  {
    low = std::min(low, axis.dot(q));
    high = std::max(high, axis.dot(q));
  }
  return {low, high};
}

/// curvesInward on one cluster, with normals fitted to its own k nearest neighbours and turned
/// toward the camera (as the crease split fits them).
bool clusterCurvesInward(const CloudXYZ& cloud, const pcl::Indices& indices, const Eigen::Vector3f& viewpoint,
                         const ConcaveSplitParams& bend)
{
  const std::size_t n = indices.size();
  const int k = std::min<int>(bend.k_neighbours, static_cast<int>(n));
  if (k < 3)
    return false;
  auto points = std::make_shared<CloudXYZ>();
  points->reserve(n);
  for (const auto i : indices)
    points->push_back(cloud.points[static_cast<std::size_t>(i)]);
  const std::vector<Eigen::Vector3f> normals = cameraFacingNormals(points, k, viewpoint);
  std::vector<std::size_t> members(n);
  std::iota(members.begin(), members.end(), std::size_t{0});
  // Fixed seed: the same cloud, the same answer.
  std::mt19937 rng(1);
  return curvesInward(*points, normals, members, bend, rng);
}
}  // namespace

std::vector<pcl::PointIndices> joinContainerInsides(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                    const Eigen::Vector3f& viewpoint, const Eigen::Vector4f& plane,
                                                    const ContainerJoinParams& params, const ConcaveSplitParams& bend,
                                                    std::vector<int>* joined_into)
{
  const std::size_t n = clusters.size();
  std::vector<int> group_of(n);
  std::iota(group_of.begin(), group_of.end(), 0);
  const std::optional<TableAxes> table = tableAxes(plane);
  if (n >= 2 && table)
  {
    const Eigen::Vector2f eye = table->horizontal(viewpoint);
    const std::vector<ClusterFootprint> footprints = clusterFootprints(cloud, clusters, *table);
    // Whether a cluster curves inward, fitted only for the clusters the geometry singles out.
    std::vector<int> inward(n, -1);
    auto curvesInwardAt = [&](std::size_t c) {
      if (inward[c] < 0)
        inward[c] = clusterCurvesInward(cloud, clusters[c].indices, viewpoint, bend) ? 1 : 0;
      return inward[c] == 1;
    };
    const float max_depth_to_width = static_cast<float>(params.max_depth_to_width);
    for (std::size_t inside = 0; inside < n; ++inside)
    {
      const ClusterFootprint& in = footprints[inside];
      if (in.points.empty())
        continue;
      int wall = -1;
      float wall_gap = std::numeric_limits<float>::infinity();
      for (std::size_t c = 0; c < n; ++c)
      {
        const ClusterFootprint& out = footprints[c];
        const Eigen::Vector2f sight = out.mean - eye;
        if (c == inside || out.points.empty() || !(sight.norm() > 0.0f) ||
            !(std::abs(in.top - out.top) <= static_cast<float>(params.max_top_difference_m)))
          continue;
        const Eigen::Vector2f along = sight.normalized(), across(-along.y(), along.x());
        const auto [in_left, in_right] = extentAlong(in, across);
        const auto [out_left, out_right] = extentAlong(out, across);
        const float overlap = std::min(in_right, out_right) - std::max(in_left, out_left);
        const float wider = std::max(in_right - in_left, out_right - out_left);
        if (!(overlap >= static_cast<float>(params.min_across_overlap) * wider))
          continue;
        // Behind the outer wall's front, within about the container's width (a round container
        // is as deep as it is wide).
        const auto [in_front, in_back] = extentAlong(in, along);
        const auto [out_front, out_back] = extentAlong(out, along);
        const float gap = in_front - out_back;
        if (in_front > out_front && in_back > out_back && in_back - out_front <= max_depth_to_width * wider &&
            gap < wall_gap)
        {
          wall = static_cast<int>(c);
          wall_gap = gap;
        }
      }
      // The outer wall is seen from outside: it never curves inward, so no wall is itself an
      // inside and one step joins each container.
      if (wall >= 0 && curvesInwardAt(inside) && !curvesInwardAt(static_cast<std::size_t>(wall)))
        group_of[inside] = wall;
    }
  }
  return mergeClusterGroups(clusters, group_of, joined_into);
}

}  // namespace fast_grasp
