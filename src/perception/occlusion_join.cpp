#include "fast_grasp/perception/occlusion_join.h"

#include "fast_grasp/perception/cluster_groups.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>

namespace fast_grasp
{
namespace
{
/// What the rule needs of one cluster: its top, its box and, per angular cell of the camera's
/// image plane, the nearest of its points (a small depth map of that cluster alone; built only when needed).
struct Piece
{
  float top = -std::numeric_limits<float>::max();
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  std::unordered_map<std::int64_t, float> nearest;  // cell -> range (m)
  std::vector<Eigen::Vector3f> sample;              // at most kClosestSample points, for the closest pair
};

constexpr std::size_t kClosestSample = 400;

/// The camera ray's cell: tangent-plane coordinates (x / z, y / z) in cells; false behind the camera.
struct CameraCells
{
  Eigen::Matrix3f to_camera;
  Eigen::Vector3f origin;
  float inverse_cell;
  bool cell(const Eigen::Vector3f& p, std::int64_t& iu, std::int64_t& iv, float& range) const
  {
    const Eigen::Vector3f q = to_camera * (p - origin);
    if (!(q.z() > 1e-6f))
      return false;
    const float u = q.x() / q.z() * inverse_cell, v = q.y() / q.z() * inverse_cell;
    if (!(std::abs(u) < 1e9f && std::abs(v) < 1e9f))
      return false;
    iu = static_cast<std::int64_t>(std::floor(u));
    iv = static_cast<std::int64_t>(std::floor(v));
    range = q.norm();
    return true;
  }
};

/// One map key per cell (cells fit in 32 bits: CameraCells::cell bounds them by 1e9). Shifted as
/// unsigned: a left shift of a negative value is undefined.
std::int64_t key(std::int64_t iu, std::int64_t iv)
{
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(iu) << 32) ^ static_cast<std::uint32_t>(iv));
}

float boxGap(const Piece& a, const Piece& b)
{
  const Eigen::Vector3f gap = (a.lo - b.hi).cwiseMax(b.lo - a.hi).cwiseMax(0.0f);
  return gap.norm();
}

int findRoot(std::vector<int>& parent, int i)
{
  while (parent[static_cast<std::size_t>(i)] != i)
    i = parent[static_cast<std::size_t>(i)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(i)])];
  return i;
}
}  // namespace

std::vector<pcl::PointIndices> joinOccludedPieces(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                  const Eigen::Vector3f& camera_position,
                                                  const Eigen::Quaternionf& camera_orientation,
                                                  const Eigen::Vector4f& plane, const OcclusionJoinParams& params,
                                                  std::vector<int>* joined_into)
{
  const std::size_t n = clusters.size();
  CameraCells camera{ camera_orientation.normalized().toRotationMatrix().transpose(), camera_position,
                      static_cast<float>(1.0 / params.angular_cell) };
  std::vector<Piece> pieces(n);
  for (std::size_t c = 0; c < n; ++c)
  {
    Piece& piece = pieces[c];
    const auto& indices = clusters[c].indices;
    const std::size_t stride = std::max<std::size_t>(1, indices.size() / kClosestSample);
    for (std::size_t k = 0; k < indices.size(); ++k)
    {
      const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(indices[k])].getVector3fMap();
      piece.top = std::max(piece.top, plane.head<3>().dot(p) + plane[3]);
      piece.lo = piece.lo.cwiseMin(p);
      piece.hi = piece.hi.cwiseMax(p);
      if (k % stride == 0)
        piece.sample.push_back(p);
    }
  }
  // The lines-of-sight maps: each cluster's, and everything else the camera saw (table,
  // background, small clusters). Built when a pair first passes the cheap tests above: most
  // frames have none.
  auto addNearest = [&](std::unordered_map<std::int64_t, float>& map, const Eigen::Vector3f& p) {
    std::int64_t iu = 0, iv = 0;
    float range = 0.0f;
    if (camera.cell(p, iu, iv, range))
    {
      auto [it, inserted] = map.emplace(key(iu, iv), range);
      if (!inserted)
        it->second = std::min(it->second, range);
    }
  };
  std::unordered_map<std::int64_t, float> rest;
  bool maps_built = false;
  auto buildMaps = [&]() {
    std::vector<bool> in_cluster(cloud.size(), false);
    for (std::size_t c = 0; c < n; ++c)
      for (const auto i : clusters[c].indices)
      {
        in_cluster[static_cast<std::size_t>(i)] = true;
        addNearest(pieces[c].nearest, cloud.points[static_cast<std::size_t>(i)].getVector3fMap());
      }
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (!in_cluster[i])
        addNearest(rest, cloud.points[i].getVector3fMap());
    maps_built = true;
  };
  // What the camera saw along the line of sight through `s`, a and b left out: the nearest
  // range of everything else within one cell. Nothing (a shadow, no return) is unknown.
  enum class Sight
  {
    Hidden,   // something nearer covers s
    Seen,     // the camera saw past s (a gap) or something at s: not one object's inside
    Unknown   // no return around that ray
  };
  auto sight = [&](const Eigen::Vector3f& s, std::size_t a, std::size_t b) {
    std::int64_t iu = 0, iv = 0;
    float range = 0.0f;
    if (!camera.cell(s, iu, iv, range))
      return Sight::Seen;
    float nearest = std::numeric_limits<float>::max();
    auto look = [&](const std::unordered_map<std::int64_t, float>& map) {
      for (std::int64_t du = -1; du <= 1; ++du)
        for (std::int64_t dv = -1; dv <= 1; ++dv)
        {
          const auto it = map.find(key(iu + du, iv + dv));
          if (it != map.end())
            nearest = std::min(nearest, it->second);
        }
    };
    for (std::size_t c = 0; c < n; ++c)
      if (c != a && c != b)
        look(pieces[c].nearest);
    look(rest);
    if (nearest == std::numeric_limits<float>::max())
      return Sight::Unknown;
    return nearest < range - static_cast<float>(params.hidden_margin_m) ? Sight::Hidden : Sight::Seen;
  };

  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  const float max_gap = static_cast<float>(params.max_gap_m);
  const float step = static_cast<float>(params.sample_step_m);
  for (std::size_t a = 0; a < n && n >= 3; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
    {
      if (std::abs(pieces[a].top - pieces[b].top) >= params.max_top_difference_m || boxGap(pieces[a], pieces[b]) > max_gap)
        continue;
      // The closest pair of the two pieces' sampled points.
      float best = std::numeric_limits<float>::max();
      Eigen::Vector3f pa = Eigen::Vector3f::Zero(), pb = Eigen::Vector3f::Zero();
      for (const Eigen::Vector3f& p : pieces[a].sample)
        for (const Eigen::Vector3f& q : pieces[b].sample)
        {
          const float d = (p - q).squaredNorm();
          if (d < best)
          {
            best = d;
            pa = p;
            pb = q;
          }
        }
      const float gap = std::sqrt(best);
      // Pieces a crease cut apart touch (nothing lies between them to be hidden).
      const int samples = static_cast<int>(std::floor(gap / step)) - 1;
      if (gap > max_gap || samples < 1)
        continue;
      if (!maps_built)
        buildMaps();
      // One object's hidden middle: nothing seen between the pieces, and most of it covered.
      int hidden = 0;
      bool seen = false;
      for (int k = 1; k <= samples && !seen; ++k)
      {
        const Sight what = sight(pa + (pb - pa) * (static_cast<float>(k) / static_cast<float>(samples + 1)), a, b);
        seen = what == Sight::Seen;
        hidden += what == Sight::Hidden;
      }
      const bool all_hidden = !seen && 2 * hidden >= samples;
      if (all_hidden)
        parent[static_cast<std::size_t>(findRoot(parent, static_cast<int>(a)))] = findRoot(parent, static_cast<int>(b));
    }

  std::vector<int> group_of(n);
  for (std::size_t c = 0; c < n; ++c)
    group_of[c] = findRoot(parent, static_cast<int>(c));
  return mergeClusterGroups(clusters, group_of, joined_into);
}

}  // namespace fast_grasp
