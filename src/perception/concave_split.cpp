#include "fast_grasp/perception/concave_split.h"

#include "fast_grasp/perception/table_footprint.h"
#include "fast_grasp/perception/union_find.h"

#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <random>

namespace fast_grasp
{
namespace
{
/// Links from the points of `group` to points of other groups, counted per other group;
/// `groupOf(i)` names point i's group. `links[i]`: i's neighbours within link_radius_m.
template <typename GroupOf>
std::map<std::size_t, int> borderLinks(const std::vector<std::vector<std::size_t>>& links, GroupOf groupOf, std::size_t group)
{
  std::map<std::size_t, int> border;
  for (std::size_t i = 0; i < links.size(); ++i)
  {
    if (groupOf(i) != group)
      continue;
    for (const std::size_t j : links[i])
      if (groupOf(j) != group)
        ++border[groupOf(j)];
  }
  return border;
}

/// Height of points above the table `plane` (a, b, c, d with its normal up).
struct HeightAboveTable
{
  explicit HeightAboveTable(const Eigen::Vector4f& plane)
    : up(plane.head<3>().normalized()), offset(plane[3] / plane.head<3>().norm())
  {
  }
  float operator()(const Eigen::Vector3f& p) const { return up.dot(p) + offset; }
  Eigen::Vector3f up;
  float offset;
};

/// The group sharing most links with the border's owner.
std::size_t mostLinked(const std::map<std::size_t, int>& border)
{
  return std::max_element(border.begin(), border.end(), [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

/// A single object seen from outside is convex or flat; a piece that curves inward everywhere is
/// the inside of a container (a mug's or a pot's far inner wall and bottom), cut from its outer
/// wall along the rim. Joins each such piece (curvesInward) to the neighbour piece it shares most
/// border links with.
void joinInsidesToTheirContainer(const CloudXYZ& points, const std::vector<std::vector<std::size_t>>& links,
                                 const std::vector<Eigen::Vector3f>& normals, const std::vector<int>& piece_of,
                                 const ConcaveSplitParams& params, UnionFind& objects)
{
  std::vector<std::vector<std::size_t>> members(objects.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    members[static_cast<std::size_t>(piece_of[i])].push_back(i);
  auto pieceOf = [&piece_of](std::size_t i) { return static_cast<std::size_t>(piece_of[i]); };
  // Fixed seed: the same cloud, the same answer.
  std::mt19937 rng(1);
  for (std::size_t piece = 0; piece < objects.size(); ++piece)
  {
    const std::map<std::size_t, int> border = borderLinks(links, pieceOf, piece);
    if (!border.empty() && curvesInward(points, normals, members[piece], params, rng))
      objects.join(piece, mostLinked(border));
  }
}

/// Nothing floats: a piece held up only by its neighbour (a pan's handle, a mug's handle) is
/// part of it. A piece stands when its lowest seen points are near the table,
/// or when the table straight under them was not seen (something nearer hides it: the object
/// may stand there, as a box behind another does, or it rests on a piece below). Joins each
/// piece that cannot stand to the neighbour it shares most border links with, among those that
/// reach lower than it: a neighbour whose bottom is above the piece's rests on it and cannot
/// hold it up (a toy lying on a box that lies on hidden objects in a pile).
void joinPiecesThatCannotStand(const CloudXYZ& points, const std::vector<std::vector<std::size_t>>& links,
                               const std::vector<int>& piece_of, const Eigen::Vector4f& plane, const TableFootprint& table,
                               const ConcaveSplitParams& params, UnionFind& objects)
{
  const HeightAboveTable heightOf(plane);
  const Eigen::Vector3f& up = heightOf.up;
  std::map<std::size_t, float> lowest;
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const std::size_t object = objects.find(static_cast<std::size_t>(piece_of[i]));
    const float height = heightOf(points.points[i].getVector3fMap());
    const auto found = lowest.find(object);
    if (found == lowest.end() || height < found->second)
      lowest[object] = height;
  }
  if (lowest.size() < 2)
    return;
  std::map<std::size_t, int> bottom_points, bottom_over_seen_table;
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const std::size_t object = objects.find(static_cast<std::size_t>(piece_of[i]));
    const Eigen::Vector3f p = points.points[i].getVector3fMap();
    const float height = heightOf(p);
    if (height > lowest[object] + static_cast<float>(params.bottom_band_m))
      continue;
    ++bottom_points[object];
    bottom_over_seen_table[object] += table.covers(p - height * up) ? 1 : 0;
  }
  auto objectOf = [&](std::size_t i) { return objects.find(static_cast<std::size_t>(piece_of[i])); };
  for (const auto& [object, low] : lowest)
  {
    if (low <= static_cast<float>(params.standing_height_m) ||
        static_cast<double>(bottom_over_seen_table[object]) <
            params.floating_seen_fraction * static_cast<double>(bottom_points[object]))
      continue;
    std::map<std::size_t, int> border = borderLinks(links, objectOf, object);
    for (auto it = border.begin(); it != border.end();)
    {
      const auto neighbour = lowest.find(it->first);
      it = neighbour == lowest.end() || neighbour->second < low ? std::next(it) : border.erase(it);
    }
    if (!border.empty())
      objects.join(object, mostLinked(border));
  }
}

/// Splits one cluster; appends its pieces (indices into the full cloud) to `out`.
void splitCluster(const CloudXYZ& cloud, const pcl::Indices& members, const Eigen::Vector3f& viewpoint,
                  const Eigen::Vector4f& plane, const TableFootprint& table, const ConcaveSplitParams& params,
                  std::vector<pcl::PointIndices>& out)
{
  const std::size_t n = members.size();
  const int k = std::min<int>(params.k_neighbours, static_cast<int>(n));
  if (k < 3)
  {
    out.emplace_back();
    out.back().indices = members;
    return;
  }
  auto points = std::make_shared<CloudXYZ>();
  points->reserve(n);
  for (const auto i : members)
    points->push_back(cloud.points[static_cast<std::size_t>(i)]);
  // One k-NN search per point serves the normal fit and the links.
  std::vector<pcl::Indices> neighbours;
  const std::vector<Eigen::Vector3f> normals = cameraFacingNormals(points, k, viewpoint, &neighbours);

  // A link is a crease when it is concave and its normals differ by more than the noise on a
  // flat face. Both ends of a crease link are crease points: they join nothing at first, so a
  // single convex-looking link along a noisy crease cannot bridge two objects.
  // Links: the k neighbours within link_radius_m, found once for every test below.
  const float link_radius_sq = static_cast<float>(params.link_radius_m * params.link_radius_m);
  std::vector<std::vector<std::size_t>> links(n);
  for (std::size_t i = 0; i < n; ++i)
    for (const auto j_index : neighbours[i])
    {
      const auto j = static_cast<std::size_t>(j_index);
      if (j != i && (points->points[i].getVector3fMap() - points->points[j].getVector3fMap()).squaredNorm() <= link_radius_sq)
        links[i].push_back(j);
    }
  const float flat_cosine = static_cast<float>(std::cos(params.concave_tolerance_rad));
  std::vector<bool> on_crease(n, false);
  for (std::size_t i = 0; i < n; ++i)
    for (const std::size_t j : links[i])
    {
      const Eigen::Vector3f offset = points->points[i].getVector3fMap() - points->points[j].getVector3fMap();
      const bool concave = (normals[i] - normals[j]).dot(offset) < 0.0f;
      if (concave && normals[i].dot(normals[j]) < flat_cosine)
        on_crease[i] = on_crease[j] = true;
    }
  UnionFind pieces(n);
  for (std::size_t i = 0; i < n; ++i)
    if (!on_crease[i])
      for (const std::size_t j : links[i])
        if (!on_crease[j])
          pieces.join(i, j);

  // Pieces of at least min_piece_points non-crease points are the objects, and so are pieces of
  // min_standing_piece_points that stand on the table (a battery lying against a cup keeps fewer
  // points than a box's face once its crease band is off; a sliver on one object hangs higher);
  // every other point (crease points, slivers) takes the piece most of its k neighbours belong to,
  // pass by pass outward from the pieces.
  constexpr int kUnassigned = -1;
  // Each piece's size (non-crease points) and lowest point above the table, in one pass.
  struct PieceStats
  {
    int size = 0;
    float lowest = std::numeric_limits<float>::max();
  };
  const HeightAboveTable heightOf(plane);
  std::map<std::size_t, PieceStats> piece_stats;
  for (std::size_t i = 0; i < n; ++i)
    if (!on_crease[i])
    {
      PieceStats& piece = piece_stats[pieces.find(i)];
      ++piece.size;
      piece.lowest = std::min(piece.lowest, heightOf(points->points[i].getVector3fMap()));
    }
  auto isObject = [&params](const PieceStats& piece) {
    return piece.size >= params.min_piece_points ||
           (params.min_standing_piece_points > 0 && piece.size >= params.min_standing_piece_points &&
            piece.lowest <= static_cast<float>(params.standing_height_m));
  };
  std::map<std::size_t, int> piece_number;
  for (const auto& [root, piece] : piece_stats)
    if (isObject(piece))
      piece_number.emplace(root, static_cast<int>(piece_number.size()));
  if (piece_number.size() <= 1)
  {
    out.emplace_back();
    out.back().indices = members;
    return;
  }
  std::vector<int> piece_of(n, kUnassigned);
  for (std::size_t i = 0; i < n; ++i)
    if (!on_crease[i])
    {
      const auto found = piece_number.find(pieces.find(i));
      if (found != piece_number.end())
        piece_of[i] = found->second;
    }
  std::vector<int> votes(piece_number.size());
  for (bool changed = true; changed;)
  {
    changed = false;
    for (std::size_t i = 0; i < n; ++i)
    {
      if (piece_of[i] != kUnassigned)
        continue;
      std::fill(votes.begin(), votes.end(), 0);
      for (const auto j : neighbours[i])
        if (piece_of[static_cast<std::size_t>(j)] != kUnassigned)
          ++votes[static_cast<std::size_t>(piece_of[static_cast<std::size_t>(j)])];
      const auto best = std::max_element(votes.begin(), votes.end());
      if (*best > 0)
      {
        piece_of[i] = static_cast<int>(best - votes.begin());
        changed = true;
      }
    }
  }
  int largest = 0;
  for (const auto& [root, number] : piece_number)
    if (piece_stats.at(root).size > piece_stats.at(std::next(piece_number.begin(), largest)->first).size)
      largest = number;
  // Points cut off from every piece (an isolated sliver) stay with the largest piece of their
  // cluster rather than vanish.
  for (int& piece : piece_of)
    piece = piece == kUnassigned ? largest : piece;
  UnionFind objects(piece_number.size());
  joinInsidesToTheirContainer(*points, links, normals, piece_of, params, objects);
  joinPiecesThatCannotStand(*points, links, piece_of, plane, table, params, objects);
  std::map<std::size_t, pcl::PointIndices> by_object;
  for (std::size_t i = 0; i < n; ++i)
    by_object[objects.find(static_cast<std::size_t>(piece_of[i]))].indices.push_back(members[i]);
  for (auto& [object, piece] : by_object)
    out.push_back(std::move(piece));
}
}  // namespace

std::vector<Eigen::Vector3f> cameraFacingNormals(const std::shared_ptr<const CloudXYZ>& points, int k,
                                                 const Eigen::Vector3f& viewpoint, std::vector<pcl::Indices>* neighbours)
{
  const std::size_t n = points->size();
  std::vector<Eigen::Vector3f> normals(n, Eigen::Vector3f::Zero());
  std::vector<pcl::Indices> found(n);
  k = std::min<int>(k, static_cast<int>(n));
  if (k >= 1)
  {
    pcl::search::KdTree<PointXYZ> tree(/*sorted=*/false);
    tree.setInputCloud(points);
    std::vector<float> squared_distances;
    for (std::size_t i = 0; i < n; ++i)
    {
      tree.nearestKSearch(static_cast<pcl::index_t>(i), k, found[i], squared_distances);
      Eigen::Vector4f fitted_plane;
      float curvature = 0.0f;
      if (!pcl::computePointNormal(*points, found[i], fitted_plane, curvature))
        continue;
      const Eigen::Vector3f normal = fitted_plane.head<3>();
      normals[i] = normal.dot(viewpoint - points->points[i].getVector3fMap()) < 0.0f ? Eigen::Vector3f(-normal) : normal;
    }
  }
  if (neighbours)
    *neighbours = std::move(found);
  return normals;
}

bool curvesInward(const CloudXYZ& points, const std::vector<Eigen::Vector3f>& normals,
                  const std::vector<std::size_t>& members, const ConcaveSplitParams& params, std::mt19937& rng)
{
  if (members.size() < 2)
    return false;
  // Bending is judged between points a few centimetres apart: neighbouring normals differ by
  // less than the sensor noise along a mug's inside.
  std::uniform_int_distribution<std::size_t> pick(0, members.size() - 1);
  const float near_sq = static_cast<float>(params.bend_min_distance_m * params.bend_min_distance_m);
  const float far_sq = static_cast<float>(params.bend_max_distance_m * params.bend_max_distance_m);
  const float bent_cosine = static_cast<float>(std::cos(params.bent_pair_rad));
  int bent = 0, concave = 0;
  for (int attempt = 0; attempt < params.bend_samples; ++attempt)
  {
    const std::size_t i = members[pick(rng)], j = members[pick(rng)];
    const Eigen::Vector3f offset = points.points[i].getVector3fMap() - points.points[j].getVector3fMap();
    const float distance_sq = offset.squaredNorm();
    if (distance_sq < near_sq || distance_sq > far_sq || normals[i].dot(normals[j]) > bent_cosine)
      continue;
    ++bent;
    concave += (normals[i] - normals[j]).dot(offset) < 0.0f ? 1 : 0;
  }
  return bent > 0 && static_cast<double>(concave) > params.concave_piece_fraction * static_cast<double>(bent);
}

std::vector<pcl::PointIndices> splitAtConcaveCreases(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                     const Eigen::Vector3f& viewpoint, const Eigen::Vector4f& plane,
                                                     const CloudXYZ& table, const ConcaveSplitParams& params)
{
  // Where the camera saw the table.
  TableFootprint table_cells(plane, params.table_cell_m);
  for (const auto& p : table.points)
    table_cells.add(p.getVector3fMap());
  std::vector<pcl::PointIndices> out;
  for (const auto& cluster : clusters)
    splitCluster(cloud, cluster.indices, viewpoint, plane, table_cells, params, out);
  std::stable_sort(out.begin(), out.end(), [](const pcl::PointIndices& a, const pcl::PointIndices& b) {
    return a.indices.size() > b.indices.size();
  });
  return out;
}

}  // namespace fast_grasp
