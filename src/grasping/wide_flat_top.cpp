#include "fast_grasp/grasping/wide_flat_top.h"

#include "fast_grasp/grasping/grasp_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace fast_grasp
{
std::string WideFlatTopParams::validate() const
{
  std::ostringstream why;
  if (!(top_band_m > 0.0 && top_band_m <= 0.1))
    why << "wide_flat_top top_band_m must be in (0, 0.1] m; ";
  if (!(min_up_cos >= 0.0 && min_up_cos <= 1.0))
    why << "wide_flat_top min_up_cos must be in [0, 1]; ";
  if (!(min_top_share > 0.0 && min_top_share <= 1.0))
    why << "wide_flat_top min_top_share must be in (0, 1]; ";
  if (!(min_height_m >= 0.0 && min_height_m <= 1.0))
    why << "wide_flat_top min_height_m must be in [0, 1] m; ";
  if (!(min_excess_over_opening_m >= -0.1 && min_excess_over_opening_m <= 0.1))
    why << "wide_flat_top min_excess_over_opening_m must be in [-0.1, 0.1] m; ";
  return why.str();
}

FlatTop measureFlatTop(const pcl::PointCloud<pcl::PointNormal>& cloud, const Eigen::Vector4f& table_plane,
                       const WideFlatTopParams& params)
{
  FlatTop top;
  const Eigen::Vector3f up = table_plane.head<3>();
  if (cloud.empty() || !up.allFinite() || !(up.norm() > 0.5f))
    return top;
  float highest = -std::numeric_limits<float>::infinity();
  std::size_t seen = 0;
  for (const auto& p : cloud)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    ++seen;
    highest = std::max(highest, up.dot(q) + table_plane[3]);
  }
  if (seen == 0)
    return top;
  const auto [u, v] = tablePlaneBasis(up);
  std::vector<Eigen::Vector2f> footprint;  // the top face's points in the table's plane
  const float band_floor = highest - static_cast<float>(params.top_band_m);
  const float up_cos = static_cast<float>(params.min_up_cos);
  for (const auto& p : cloud)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    const Eigen::Vector3f n = p.getNormalVector3fMap();
    if (q.allFinite() && n.allFinite() && up.dot(q) + table_plane[3] >= band_floor && n.dot(up) >= up_cos)
      footprint.emplace_back(u.dot(q), v.dot(q));
  }
  top.top_share = static_cast<double>(footprint.size()) / static_cast<double>(seen);
  top.flat = !footprint.empty() && top.top_share >= params.min_top_share && highest >= params.min_height_m;
  if (!top.flat)
    return top;
  // The narrowest extent over directions: 36 steps of 5 degrees over half a turn. A step can
  // miss the narrowest direction by 2.5 degrees, so the width read may exceed the true one by
  // up to the top's length x sin(2.5 deg) (9 mm on a 21 cm box at the worst angle): a top reads
  // wider, never narrower, and one truly narrower than the opening plus the margin is refused
  // only if it is longer than (opening + margin - width) / sin(2.5 deg) (23 cm for a 9.5 cm top).
  constexpr int kDirections = 36;
  double narrowest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < kDirections; ++k)
  {
    const double angle = M_PI * k / kDirections;
    const Eigen::Vector2f direction(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)));
    float low = std::numeric_limits<float>::infinity(), high = -low;
    for (const Eigen::Vector2f& q : footprint)
    {
      low = std::min(low, direction.dot(q));
      high = std::max(high, direction.dot(q));
    }
    narrowest = std::min(narrowest, static_cast<double>(high - low));
  }
  top.min_width_m = narrowest;
  return top;
}

bool isWideFlatTop(const FlatTop& top, double max_opening_m, const WideFlatTopParams& params)
{
  return params.enabled && top.flat && top.min_width_m > max_opening_m + params.min_excess_over_opening_m;
}

}  // namespace fast_grasp
