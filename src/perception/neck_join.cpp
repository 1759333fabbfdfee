#include "fast_grasp/perception/neck_join.h"

#include "fast_grasp/perception/cluster_groups.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fast_grasp
{
std::vector<pcl::PointIndices> joinNecksToLyingBodies(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                      const Eigen::Vector4f& plane, const NeckJoinParams& params,
                                                      std::vector<int>* joined_into)
{
  const std::size_t n = clusters.size();
  std::vector<int> body_of(n, -1);
  const std::optional<TableAxes> table = tableAxes(plane);
  if (params.min_elongation > 0.0 && n >= 2 && table)
  {
    const std::vector<ClusterFootprint> shapes = clusterFootprints(cloud, clusters, *table);
    const float standing = static_cast<float>(params.standing_height_m);
    for (std::size_t body = 0; body < n; ++body)
    {
      const ClusterFootprint& b = shapes[body];
      if (b.points.size() < 3 || !(b.low <= standing))
        continue;
      Eigen::Matrix2f covariance = Eigen::Matrix2f::Zero();
      for (const auto& q : b.points)
        covariance += (q - b.mean) * (q - b.mean).transpose();
      covariance /= static_cast<float>(b.points.size());
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2f> spread(covariance);
      const float across_sd = std::sqrt(std::max(spread.eigenvalues()[0], 0.0f));
      const float along_sd = std::sqrt(std::max(spread.eigenvalues()[1], 0.0f));
      if (!(along_sd >= static_cast<float>(params.min_elongation) * across_sd))
        continue;
      const Eigen::Vector2f axis = spread.eigenvectors().col(1);
      const Eigen::Vector2f across_axis(-axis.y(), axis.x());
      // Points spread evenly across a width have sqrt(3) standard deviations to its edge.
      const float half_width = std::sqrt(3.0f) * across_sd;
      for (std::size_t neck = 0; neck < n; ++neck)
      {
        const ClusterFootprint& k = shapes[neck];
        if (neck == body || body_of[neck] >= 0 || k.points.empty() || k.points.size() >= b.points.size() ||
            !(k.low > standing) || !(k.top < b.top && k.top > 0.5f * b.top))
          continue;
        const Eigen::Vector2f from_body = k.mean - b.mean;
        const float side = from_body.dot(axis) >= 0.0f ? 1.0f : -1.0f;
        if (std::abs(from_body.dot(across_axis)) > half_width)
          continue;
        float body_end = -std::numeric_limits<float>::infinity();
        for (const auto& q : b.points)
          body_end = std::max(body_end, side * (q - b.mean).dot(axis));
        float neck_start = std::numeric_limits<float>::infinity();
        for (const auto& q : k.points)
          neck_start = std::min(neck_start, side * (q - b.mean).dot(axis));
        const float neck_middle = side * from_body.dot(axis);
        if (neck_middle > body_end && neck_start - body_end <= static_cast<float>(params.max_gap_m))
          body_of[neck] = static_cast<int>(body);
      }
    }
  }
  // A neck joins its body; a body lies on the table and a neck does not, so no body is itself
  // a neck and one step does.
  std::vector<int> group_of(n);
  for (std::size_t c = 0; c < n; ++c)
    group_of[c] = body_of[c] >= 0 ? body_of[c] : static_cast<int>(c);
  return mergeClusterGroups(clusters, group_of, joined_into);
}

}  // namespace fast_grasp
