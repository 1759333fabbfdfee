#include "fast_grasp/grasping/unseen_part.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fast_grasp
{
namespace
{
constexpr float kEmpty = std::numeric_limits<float>::infinity();

/// A depth image of the cloud as one camera saw it: per cell the nearest point. Image
/// coordinates are tangents of the ray angles (pinhole model), so a camera ray is one cell.
class ViewGrid
{
public:
  template <typename PointT>
  bool build(const pcl::PointCloud<PointT>& cloud, const std::vector<int>& finite, const Eigen::Vector3f& origin,
             const Eigen::Vector3f& look_at, double cell_m, double min_cell_m, int max_cells_per_side)
  {
    origin_ = origin;
    forward_ = look_at - origin;
    if (forward_.norm() < 1e-6f)
      return false;
    forward_.normalize();
    right_ = forward_.unitOrthogonal();
    up_ = forward_.cross(right_);

    // Image coordinates of every point; points behind the camera cannot be seen by it.
    std::vector<Eigen::Vector3f> projected;
    projected.reserve(finite.size());
    Eigen::Vector2f low(kEmpty, kEmpty);
    Eigen::Vector2f high(-kEmpty, -kEmpty);
    double depth_sum = 0.0;
    for (int index : finite)
    {
      const auto& p = cloud.points[static_cast<std::size_t>(index)];
      const Eigen::Vector3f d = Eigen::Vector3f(p.x, p.y, p.z) - origin_;
      const float depth = d.dot(forward_);
      if (depth <= 1e-6f)
        continue;
      const Eigen::Vector3f q(d.dot(right_) / depth, d.dot(up_) / depth, depth);
      projected.push_back(q);
      indices_.push_back(index);
      low = low.cwiseMin(q.head<2>());
      high = high.cwiseMax(q.head<2>());
      depth_sum += depth;
    }
    if (projected.empty())
      return false;
    const double mean_depth = depth_sum / static_cast<double>(projected.size());
    const Eigen::Vector2f extent = (high - low).cwiseMax(1e-9f);
    if (!(cell_m > 0.0))
    {
      // Mean spacing from the projected area; x2.5 so a cell always holds a point inside.
      const double area_m2 = static_cast<double>(extent.x()) * extent.y() * mean_depth * mean_depth;
      cell_m = 2.5 * std::sqrt(area_m2 / static_cast<double>(projected.size()));
      cell_m = std::max({ cell_m, min_cell_m, 1e-4 });
    }
    cell_tan_ = static_cast<float>(cell_m / mean_depth);
    const float max_extent = std::max(extent.x(), extent.y());
    if (max_extent / cell_tan_ > static_cast<float>(max_cells_per_side - 3))
      cell_tan_ = max_extent / static_cast<float>(max_cells_per_side - 3);
    cell_m_ = static_cast<double>(cell_tan_) * mean_depth;
    // One empty ring around the cloud so the silhouette is always a boundary.
    low_ = low - Eigen::Vector2f::Constant(cell_tan_);
    cols_ = static_cast<int>(std::floor(extent.x() / cell_tan_)) + 3;
    rows_ = static_cast<int>(std::floor(extent.y() / cell_tan_)) + 3;
    depth_.assign(static_cast<std::size_t>(cols_) * rows_, kEmpty);
    nearest_.assign(depth_.size(), -1);
    for (std::size_t i = 0; i < projected.size(); ++i)
    {
      const int cell = cellOf(projected[i].head<2>());
      if (cell >= 0 && projected[i].z() < depth_[cell])
      {
        depth_[cell] = projected[i].z();
        nearest_[cell] = indices_[i];
      }
    }
    return true;
  }

  /// Cells whose nearest point is on the silhouette or on the near side of a depth jump.
  std::vector<int> boundaryPoints(double depth_jump_m) const
  {
    std::vector<int> boundary;
    for (int row = 0; row < rows_; ++row)
      for (int col = 0; col < cols_; ++col)
      {
        const float depth = depth_[row * cols_ + col];
        if (depth == kEmpty)
          continue;
        bool is_boundary = false;
        for (int dr = -1; dr <= 1 && !is_boundary; ++dr)
          for (int dc = -1; dc <= 1 && !is_boundary; ++dc)
          {
            const int r = row + dr;
            const int c = col + dc;
            if (r < 0 || c < 0 || r >= rows_ || c >= cols_)
              is_boundary = true;
            else
            {
              const float neighbour = depth_[r * cols_ + c];
              is_boundary = neighbour == kEmpty || neighbour - depth > static_cast<float>(depth_jump_m);
            }
          }
        if (is_boundary)
          boundary.push_back(nearest_[row * cols_ + col]);
      }
    return boundary;
  }

  /// True when this camera sees `p` as free space: outside the object's silhouette, or in
  /// front of the seen surface by more than `tolerance_m`.
  bool seesAsFree(const Eigen::Vector3f& p, float tolerance_m) const
  {
    const Eigen::Vector3f d = p - origin_;
    const float depth = d.dot(forward_);
    if (depth <= 1e-6f)
      return false;  // behind this camera: it cannot vouch for the point
    const int cell = cellOf(Eigen::Vector2f(d.dot(right_) / depth, d.dot(up_) / depth));
    if (cell < 0)
      return true;
    return depth_[cell] == kEmpty || depth < depth_[cell] - tolerance_m;
  }

  double cellMetres() const { return cell_m_; }
  const Eigen::Vector3f& origin() const { return origin_; }

private:
  int cellOf(const Eigen::Vector2f& uv) const
  {
    const int col = static_cast<int>(std::floor((uv.x() - low_.x()) / cell_tan_));
    const int row = static_cast<int>(std::floor((uv.y() - low_.y()) / cell_tan_));
    if (col < 0 || row < 0 || col >= cols_ || row >= rows_)
      return -1;
    return row * cols_ + col;
  }

  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  Eigen::Vector3f forward_ = Eigen::Vector3f::UnitZ();
  Eigen::Vector3f right_ = Eigen::Vector3f::UnitX();
  Eigen::Vector3f up_ = Eigen::Vector3f::UnitY();
  Eigen::Vector2f low_ = Eigen::Vector2f::Zero();
  float cell_tan_ = 1.0f;
  double cell_m_ = 0.0;
  int cols_ = 0;
  int rows_ = 0;
  std::vector<int> indices_;
  std::vector<float> depth_;  // nearest depth per cell, kEmpty if none
  std::vector<int> nearest_;  // cloud index of that point
};

/// Indices of the points of `cloud` with finite coordinates, and their centroid (unset when
/// there is none).
template <typename PointT>
std::vector<int> finiteIndices(const pcl::PointCloud<PointT>& cloud, Eigen::Vector3f& centroid)
{
  std::vector<int> finite;
  finite.reserve(cloud.size());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < cloud.size(); ++i)
  {
    const auto& p = cloud.points[i];
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
    {
      finite.push_back(static_cast<int>(i));
      sum += Eigen::Vector3d(p.x, p.y, p.z);
    }
  }
  if (!finite.empty())
    centroid = (sum / static_cast<double>(finite.size())).cast<float>();
  return finite;
}

/// The median over 1 cm slices along `along` of the points' extent across `across` once each
/// slice is joined with its mirror image about across = plane_offset. Only slices under the
/// level top (`level_along`: its points' positions along the axis) count, where the plane was
/// found: a pan mirrored about its handle's top is not as wide as its dish. Slices with fewer
/// than 5 points are skipped; 0 when none is left.
double medianMirroredWidth(const pcl::PointCloud<pcl::PointNormal>& cloud, const std::vector<int>& finite,
                           const Eigen::Vector3f& along, const Eigen::Vector3f& across, float along_low,
                           float plane_offset, const std::vector<float>& level_along)
{
  constexpr float kSliceM = 0.01f;
  constexpr std::size_t kMinSlicePoints = 5;
  struct Slice
  {
    float low = kEmpty, high = -kEmpty;
    std::size_t points = 0;
    bool under_level_top = false;
  };
  const auto sliceOf = [&](float position) {
    return static_cast<std::size_t>(std::max(0.0f, (position - along_low) / kSliceM));
  };
  std::vector<Slice> slices;
  for (int index : finite)
  {
    const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(index)].getVector3fMap();
    const std::size_t slice = sliceOf(p.dot(along));
    if (slice >= slices.size())
      slices.resize(slice + 1);
    slices[slice].low = std::min(slices[slice].low, p.dot(across));
    slices[slice].high = std::max(slices[slice].high, p.dot(across));
    ++slices[slice].points;
  }
  for (float position : level_along)
    if (sliceOf(position) < slices.size())
      slices[sliceOf(position)].under_level_top = true;
  std::vector<float> widths;
  for (const Slice& slice : slices)
    if (slice.points >= kMinSlicePoints && slice.under_level_top)
      widths.push_back(std::max(slice.high, 2.0f * plane_offset - slice.low) -
                       std::min(slice.low, 2.0f * plane_offset - slice.high));
  if (widths.empty())
    return 0.0;
  std::nth_element(widths.begin(), widths.begin() + static_cast<std::ptrdiff_t>(widths.size() / 2), widths.end());
  return static_cast<double>(widths[widths.size() / 2]);
}
}  // namespace

MirrorCompletion completeByMirror(const pcl::PointCloud<pcl::PointNormal>& cloud, const Eigen::Vector3f& sensor_origin,
                                  const Eigen::Vector4f& table_plane, const MirrorCompletionParams& params)
{
  // Points within this of level across the axis (sin ~6 deg) and normals within ~25 deg of up
  // make the level top; fewer than kMinLevelPoints of them and there is no top to mirror about.
  constexpr float kLevelAcross = 0.1f;
  constexpr float kLevelUp = 0.9f;
  constexpr std::size_t kMinLevelPoints = 10;
  constexpr float kTopFraction = 0.75f;
  MirrorCompletion completion;
  const float up_norm = table_plane.head<3>().norm();
  if (!(params.min_elongation >= 1.0) || !(params.max_free_fraction >= 0.0 && params.max_free_fraction <= 1.0))
  {
    completion.failure = "invalid MirrorCompletionParams (min_elongation below 1 or free fraction outside [0, 1])";
    return completion;
  }
  if (!table_plane.allFinite() || !(up_norm > 1e-6f))
  {
    completion.failure = "no table plane to stand the mirror plane on";
    return completion;
  }
  Eigen::Vector3f centroid;
  const std::vector<int> finite = finiteIndices(cloud, centroid);
  if (finite.size() < kMinLevelPoints)
  {
    completion.failure = "too few finite points";
    return completion;
  }
  ViewGrid grid;
  if (!sensor_origin.allFinite() || !grid.build(cloud, finite, sensor_origin, centroid, 0.0, 0.0, 256))
  {
    completion.failure = "the sensor origin coincides with the object or sees none of it";
    return completion;
  }
  const auto tolerance_m = static_cast<float>(grid.cellMetres());
  const Eigen::Vector3f up = table_plane.head<3>() / up_norm;
  const Eigen::Vector3f e1 = up.unitOrthogonal();
  const Eigen::Vector3f e2 = up.cross(e1);
  // The footprint's long axis: principal direction of the points projected on the table.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int index : finite)
  {
    const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(index)].getVector3fMap();
    mean += Eigen::Vector2d(p.dot(e1), p.dot(e2));
  }
  mean /= static_cast<double>(finite.size());
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  for (int index : finite)
  {
    const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(index)].getVector3fMap();
    const Eigen::Vector2d d = Eigen::Vector2d(p.dot(e1), p.dot(e2)) - mean;
    covariance += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(covariance);
  const Eigen::Vector2d major = eigen.eigenvectors().col(1);
  const Eigen::Vector3f along = (static_cast<float>(major.x()) * e1 + static_cast<float>(major.y()) * e2).normalized();
  const Eigen::Vector3f across = up.cross(along);
  float along_low = kEmpty, along_high = -kEmpty, across_low = kEmpty, across_high = -kEmpty;
  float top_height = -kEmpty;
  std::vector<float> level_across, level_along, level_heights;
  for (int index : finite)
  {
    const auto& q = cloud.points[static_cast<std::size_t>(index)];
    const Eigen::Vector3f p = q.getVector3fMap();
    along_low = std::min(along_low, p.dot(along));
    along_high = std::max(along_high, p.dot(along));
    across_low = std::min(across_low, p.dot(across));
    across_high = std::max(across_high, p.dot(across));
    const float height = up.dot(p) + table_plane(3) / up_norm;
    top_height = std::max(top_height, height);
    Eigen::Vector3f n(q.normal_x, q.normal_y, q.normal_z);
    if (!n.allFinite() || n.norm() < 1e-6f)
      continue;
    n.normalize();
    if (n.dot(up) < 0.0f)
      n = -n;
    if (std::abs(n.dot(across)) < kLevelAcross && n.dot(up) > kLevelUp)
    {
      level_across.push_back(p.dot(across));
      level_along.push_back(p.dot(along));
      level_heights.push_back(height);
    }
  }
  const float width = across_high - across_low;
  if (!(width > 1e-4f) || (along_high - along_low) < static_cast<float>(params.min_elongation) * width)
  {
    completion.failure = "footprint not elongated";
    return completion;
  }
  if (level_across.size() < kMinLevelPoints)
  {
    completion.failure = "no level top to mirror about";
    return completion;
  }
  // The level part must be the top: most of it in the top quarter of the height. A pan's
  // level part is the bottom of its inside, below its rim, and a pan is no closed body whose
  // hidden side mirrors its seen one.
  std::nth_element(level_heights.begin(), level_heights.begin() + static_cast<std::ptrdiff_t>(level_heights.size() / 2),
                   level_heights.end());
  if (level_heights[level_heights.size() / 2] < kTopFraction * top_height)
  {
    completion.failure = "its level part is not its top (a container's inside, a step)";
    return completion;
  }
  // The middle of the level top: the median over occupied bins (one point spacing wide) of
  // their points' mean position, so the denser near half of a perspective view does not pull
  // the plane toward the camera.
  const float bin_m = std::max(1e-3f, tolerance_m / 2.5f);
  std::sort(level_across.begin(), level_across.end());
  std::vector<float> bin_means;
  for (std::size_t begin = 0; begin < level_across.size();)
  {
    const int bin = static_cast<int>(std::floor((level_across[begin] - across_low) / bin_m));
    std::size_t end = begin;
    double bin_sum = 0.0;
    while (end < level_across.size() && static_cast<int>(std::floor((level_across[end] - across_low) / bin_m)) == bin)
      bin_sum += static_cast<double>(level_across[end++]);
    bin_means.push_back(static_cast<float>(bin_sum / static_cast<double>(end - begin)));
    begin = end;
  }
  const float plane_offset = bin_means[bin_means.size() / 2];
  std::size_t seen_free = 0;
  for (int index : finite)
  {
    const Eigen::Vector3f p = cloud.points[static_cast<std::size_t>(index)].getVector3fMap();
    const Eigen::Vector3f m = p - 2.0f * (p.dot(across) - plane_offset) * across;
    if (grid.seesAsFree(m, tolerance_m))
      ++seen_free;
    else
      completion.mirrored.push_back(pcl::PointXYZ(m.x(), m.y(), m.z()));
  }
  if (static_cast<double>(seen_free) > params.max_free_fraction * static_cast<double>(finite.size()))
  {
    completion.mirrored.clear();
    completion.failure = "not mirror symmetric: " + std::to_string(seen_free) + " of " + std::to_string(finite.size()) +
                         " mirrored points fall where the camera saw free space";
    return completion;
  }
  completion.along = along;
  completion.across = across;
  completion.length_m = static_cast<double>(along_high - along_low);
  completion.width_m = medianMirroredWidth(cloud, finite, along, across, along_low, plane_offset, level_along);
  return completion;
}

template <typename PointT>
UnseenPart buildUnseenPart(const pcl::PointCloud<PointT>& cloud, const std::vector<Eigen::Vector3f>& sensor_origins,
                           const UnseenPartParams& params, const std::optional<Eigen::Vector4f>& table_plane)
{
  UnseenPart unseen;
  if (sensor_origins.empty())
  {
    unseen.failure = "no sensor origin: the unseen part is defined by the camera rays";
    return unseen;
  }
  if (!(params.extension_m >= 0.0) || params.step_m < 0.0 || params.grid_cell_m < 0.0 || params.min_grid_cell_m < 0.0 ||
      params.max_grid_cells_per_side < 8)
  {
    unseen.failure = "invalid UnseenPartParams (negative length or grid smaller than 8 cells)";
    return unseen;
  }
  Eigen::Vector3f centroid;
  const std::vector<int> finite = finiteIndices(cloud, centroid);
  if (finite.empty())
  {
    unseen.failure = "no finite point";
    return unseen;
  }

  std::vector<ViewGrid> grids(sensor_origins.size());
  for (std::size_t s = 0; s < sensor_origins.size(); ++s)
  {
    const double cell_m = s == 0 ? params.grid_cell_m : grids[0].cellMetres();
    if (!grids[s].build(cloud, finite, sensor_origins[s], centroid, cell_m, params.min_grid_cell_m,
                        params.max_grid_cells_per_side))
    {
      unseen.failure = "sensor origin " + std::to_string(s) + " coincides with the object or sees none of it";
      return unseen;
    }
  }
  unseen.grid_cell_m = grids[0].cellMetres();
  const double step_m = params.step_m > 0.0 ? params.step_m : std::max(unseen.grid_cell_m, 1e-3);
  const int steps = static_cast<int>(std::ceil(params.extension_m / step_m));
  const float tolerance_m = static_cast<float>(unseen.grid_cell_m);

  for (std::size_t s = 0; s < grids.size(); ++s)
  {
    for (int index : grids[s].boundaryPoints(params.depth_jump_m))
    {
      const auto& b = cloud.points[static_cast<std::size_t>(index)];
      const Eigen::Vector3f start(b.x, b.y, b.z);
      const Eigen::Vector3f ray = (start - grids[s].origin()).normalized();
      unseen.boundary_indices.push_back(index);
      for (int k = 1; k <= steps; ++k)
      {
        const Eigen::Vector3f q = start + ray * static_cast<float>(k * step_m);
        if (table_plane && table_plane->head<3>().dot(q) + (*table_plane)(3) < -params.table_clearance_m)
          break;  // the ray went into the table; everything farther is inside it too
        bool hidden_from_all = true;
        for (std::size_t other = 0; other < grids.size() && hidden_from_all; ++other)
          if (other != s && grids[other].seesAsFree(q, tolerance_m))
            hidden_from_all = false;
        if (hidden_from_all)
          unseen.points.push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
      }
    }
  }
  unseen.points.width = static_cast<std::uint32_t>(unseen.points.size());
  unseen.points.height = 1;
  unseen.points.is_dense = true;
  return unseen;
}

template UnseenPart buildUnseenPart(const pcl::PointCloud<pcl::PointXYZ>&, const std::vector<Eigen::Vector3f>&,
                                    const UnseenPartParams&, const std::optional<Eigen::Vector4f>&);
template UnseenPart buildUnseenPart(const pcl::PointCloud<pcl::PointNormal>&, const std::vector<Eigen::Vector3f>&,
                                    const UnseenPartParams&, const std::optional<Eigen::Vector4f>&);

}  // namespace fast_grasp
