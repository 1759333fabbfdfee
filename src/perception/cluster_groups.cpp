#include "fast_grasp/perception/cluster_groups.h"

#include <algorithm>
#include <map>
#include <numeric>

namespace fast_grasp
{
std::vector<pcl::PointIndices> mergeClusterGroups(const std::vector<pcl::PointIndices>& clusters,
                                                  const std::vector<int>& group_of, std::vector<int>* joined_into)
{
  const std::size_t n = clusters.size();
  std::map<int, int> group_output;
  std::vector<pcl::PointIndices> joined;
  std::vector<int> output_of(n);
  for (std::size_t c = 0; c < n; ++c)
  {
    const auto [found, added] = group_output.emplace(group_of[c], static_cast<int>(joined.size()));
    if (added)
    {
      joined.emplace_back();
      joined.back().header = clusters[c].header;
    }
    output_of[c] = found->second;
    auto& indices = joined[static_cast<std::size_t>(found->second)].indices;
    indices.insert(indices.end(), clusters[c].indices.begin(), clusters[c].indices.end());
  }
  // Largest first, as the clusters came.
  std::vector<int> order(joined.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) {
    return joined[static_cast<std::size_t>(x)].indices.size() > joined[static_cast<std::size_t>(y)].indices.size();
  });
  std::vector<int> rank(joined.size());
  std::vector<pcl::PointIndices> sorted;
  sorted.reserve(joined.size());
  for (std::size_t r = 0; r < order.size(); ++r)
  {
    rank[static_cast<std::size_t>(order[r])] = static_cast<int>(r);
    sorted.push_back(std::move(joined[static_cast<std::size_t>(order[r])]));
  }
  if (joined_into)
  {
    joined_into->resize(n);
    for (std::size_t c = 0; c < n; ++c)
      (*joined_into)[c] = rank[static_cast<std::size_t>(output_of[c])];
  }
  return sorted;
}

std::optional<TableAxes> tableAxes(const Eigen::Vector4f& plane)
{
  const float normal_length = plane.head<3>().norm();
  if (!(normal_length > 0.0f))
    return std::nullopt;
  TableAxes table;
  table.up = plane.head<3>() / normal_length;
  table.offset = plane[3] / normal_length;
  table.e1 = table.up.unitOrthogonal();
  table.e2 = table.up.cross(table.e1);
  return table;
}

std::vector<ClusterFootprint> clusterFootprints(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                const TableAxes& table)
{
  std::vector<ClusterFootprint> footprints(clusters.size());
  for (std::size_t c = 0; c < clusters.size(); ++c)
  {
    ClusterFootprint& footprint = footprints[c];
    footprint.points.reserve(clusters[c].indices.size());
    for (const auto i : clusters[c].indices)
    {
      const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(i)].getVector3fMap();
      const float height = table.height(p);
      footprint.low = std::min(footprint.low, height);
      footprint.top = std::max(footprint.top, height);
      footprint.points.push_back(table.horizontal(p));
      footprint.mean += footprint.points.back();
    }
    if (!footprint.points.empty())
      footprint.mean /= static_cast<float>(footprint.points.size());
  }
  return footprints;
}

}  // namespace fast_grasp
