#include "fast_grasp/perception/grid_clusters.h"

#include "fast_grasp/perception/union_find.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

namespace fast_grasp
{
std::optional<std::vector<pcl::PointIndices>> gridEuclideanClusters(const CloudXYZ& cloud, const pcl::Indices& indices,
                                                                    double tolerance_m, int min_points, int max_points,
                                                                    std::size_t max_cells)
{
  std::vector<pcl::PointIndices> clusters;
  if (!(tolerance_m > 0.0))
    return std::nullopt;
  pcl::Indices points;
  points.reserve(indices.size());
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), high = -low;
  for (const auto i : indices)
  {
    const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(i)].getVector3fMap();
    if (!p.allFinite())
      continue;
    points.push_back(i);
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  if (points.empty())
    return clusters;
  // Any two points of one cell are closer than the tolerance (the cell's diagonal is a hair
  // shorter); two points closer than it lie at most two cells apart along each axis.
  const double cell = tolerance_m / std::sqrt(3.0) * (1.0 - 1e-6);
  constexpr long kPad = 2;
  std::array<long, 3> dims{};
  double total = 1.0;
  for (int a = 0; a < 3; ++a)
  {
    // Checked before the cast: finite but far-flung points (1e30 m) would overflow a long.
    const double cells_along = std::floor((static_cast<double>(high[a]) - static_cast<double>(low[a])) / cell);
    if (!(cells_along < static_cast<double>(max_cells)))
      return std::nullopt;
    dims[static_cast<std::size_t>(a)] = static_cast<long>(cells_along) + 1 + 2 * kPad;
    total *= static_cast<double>(dims[static_cast<std::size_t>(a)]);
  }
  if (total > static_cast<double>(max_cells))
    return std::nullopt;
  auto gridIndex = [&](const Eigen::Vector3f& p) {
    long index = 0;
    for (int a = 2; a >= 0; --a)
      index = index * dims[static_cast<std::size_t>(a)] + static_cast<long>(std::floor((p[a] - low[a]) / cell)) + kPad;
    return index;
  };
  // Occupied cells and their points (counting sort by cell).
  std::vector<int> cell_at(static_cast<std::size_t>(total), -1);
  std::vector<long> grid_of_cell;
  std::vector<int> cell_of_point(points.size());
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    const long g = gridIndex(cloud.points[static_cast<std::size_t>(points[k])].getVector3fMap());
    int& cell_id = cell_at[static_cast<std::size_t>(g)];
    if (cell_id < 0)
    {
      cell_id = static_cast<int>(grid_of_cell.size());
      grid_of_cell.push_back(g);
    }
    cell_of_point[k] = cell_id;
  }
  const std::size_t cells = grid_of_cell.size();
  std::vector<std::size_t> start(cells + 1, 0);
  for (const int c : cell_of_point)
    ++start[static_cast<std::size_t>(c) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<Eigen::Vector3f> members(points.size());
  std::vector<pcl::index_t> member_index(points.size());
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t k = 0; k < points.size(); ++k)
    {
      const std::size_t slot = fill[static_cast<std::size_t>(cell_of_point[k])]++;
      members[slot] = cloud.points[static_cast<std::size_t>(points[k])].getVector3fMap();
      member_index[slot] = points[k];
    }
  }
  // Forward neighbour offsets (each unordered cell pair once), one cell away first.
  std::vector<long> near_offsets, far_offsets;
  for (long dz = -2; dz <= 2; ++dz)
    for (long dy = -2; dy <= 2; ++dy)
      for (long dx = -2; dx <= 2; ++dx)
      {
        if (std::make_tuple(dz, dy, dx) <= std::make_tuple(0L, 0L, 0L))
          continue;
        const long offset = (dz * dims[1] + dy) * dims[0] + dx;
        (std::max({ std::abs(dx), std::abs(dy), std::abs(dz) }) <= 1 ? near_offsets : far_offsets).push_back(offset);
      }
  const float tolerance_sq = static_cast<float>(tolerance_m * tolerance_m);
  UnionFind sets(cells);  // over the occupied cells
  auto linked = [&](std::size_t a, std::size_t b) {
    for (std::size_t i = start[a]; i < start[a + 1]; ++i)
      for (std::size_t j = start[b]; j < start[b + 1]; ++j)
        if ((members[i] - members[j]).squaredNorm() < tolerance_sq)
          return true;
    return false;
  };
  for (const auto* offsets : { &near_offsets, &far_offsets })
    for (std::size_t a = 0; a < cells; ++a)
      for (const long offset : *offsets)
      {
        const int b = cell_at[static_cast<std::size_t>(grid_of_cell[a] + offset)];
        if (b >= 0 && sets.find(a) != sets.find(static_cast<std::size_t>(b)) && linked(a, static_cast<std::size_t>(b)))
          sets.join(a, static_cast<std::size_t>(b));
      }
  // One cluster per set, in the order of their smallest point index after sorting.
  std::vector<int> cluster_of_root(cells, -1);
  for (std::size_t a = 0; a < cells; ++a)
  {
    const std::size_t root = sets.find(a);
    if (cluster_of_root[root] < 0)
    {
      cluster_of_root[root] = static_cast<int>(clusters.size());
      clusters.emplace_back();
    }
    auto& cluster = clusters[static_cast<std::size_t>(cluster_of_root[root])].indices;
    cluster.insert(cluster.end(), member_index.begin() + static_cast<long>(start[a]),
                   member_index.begin() + static_cast<long>(start[a + 1]));
  }
  clusters.erase(std::remove_if(clusters.begin(), clusters.end(),
                                [&](const pcl::PointIndices& c) {
                                  return static_cast<int>(c.indices.size()) < min_points ||
                                         static_cast<int>(c.indices.size()) > max_points;
                                }),
                 clusters.end());
  for (auto& c : clusters)
  {
    std::sort(c.indices.begin(), c.indices.end());
    c.header = cloud.header;
  }
  std::sort(clusters.begin(), clusters.end(), [](const pcl::PointIndices& a, const pcl::PointIndices& b) {
    return a.indices.size() != b.indices.size() ? a.indices.size() > b.indices.size() : a.indices.front() < b.indices.front();
  });
  return clusters;
}

}  // namespace fast_grasp
