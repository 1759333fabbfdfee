#include "fast_grasp/perception/cloud_preprocess.h"

#include <pcl/filters/voxel_grid.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>

namespace fast_grasp
{
namespace
{
std::string validateParams(const PreprocessParams& params)
{
  if (!(params.reach_m > 0.0) || !std::isfinite(params.reach_m))
    return "reach_m must be positive and finite";
  if (!(params.leaf_size_m >= 0.0) || !std::isfinite(params.leaf_size_m))
    return "leaf_size_m must be >= 0 and finite";
  if (params.pixel_stride < 1)
    return "pixel_stride must be >= 1";
  if (params.max_sampled_points < 1)
    return "max_sampled_points must be >= 1";
  if (!(params.min_z_m < params.max_z_m))
    return "min_z_m must be below max_z_m";
  if (!params.reach_centre_m.allFinite())
    return "reach_centre_m must be finite";
  return {};
}

// Points of a pcl::PointCloud, row-major.
template <typename PointT>
class PclSource
{
public:
  explicit PclSource(const pcl::PointCloud<PointT>& cloud)
    : cloud_(cloud)
    , organised_(cloud.height > 1 && static_cast<std::size_t>(cloud.width) * cloud.height == cloud.size())
    , width_(organised_ ? cloud.width : cloud.size())
  {
  }
  std::size_t size() const { return cloud_.size(); }
  bool organised() const { return organised_; }
  std::size_t width() const { return width_; }
  std::size_t height() const { return organised_ ? cloud_.height : 1; }
  Eigen::Vector3f at(std::size_t row, std::size_t col) const
  {
    const PointT& p = cloud_.points[row * width_ + col];
    return Eigen::Vector3f(p.x, p.y, p.z);
  }

private:
  const pcl::PointCloud<PointT>& cloud_;
  bool organised_;
  std::size_t width_;
};

// Points of a raw byte buffer (PointCloud2 layout).
class RawSource
{
public:
  explicit RawSource(const RawCloudView& view) : view_(view) {}
  std::size_t size() const { return static_cast<std::size_t>(view_.width) * view_.height; }
  bool organised() const { return view_.height > 1; }
  std::size_t width() const { return view_.width; }
  std::size_t height() const { return view_.height; }
  Eigen::Vector3f at(std::size_t row, std::size_t col) const
  {
    const std::uint8_t* p = view_.data + row * view_.row_step + col * view_.point_step;
    float xyz[3];
    std::memcpy(&xyz[0], p + view_.x_offset, sizeof(float));
    std::memcpy(&xyz[1], p + view_.y_offset, sizeof(float));
    std::memcpy(&xyz[2], p + view_.z_offset, sizeof(float));
    return Eigen::Vector3f(xyz[0], xyz[1], xyz[2]);
  }

private:
  const RawCloudView& view_;
};

std::size_t ceilDiv(std::size_t a, std::size_t b) { return (a + b - 1) / b; }

// The stride actually used: pixel_stride for an organised cloud (1 for an unorganised one),
// raised to the smallest value whose sampled count fits max_sampled_points.
std::size_t samplingStride(std::size_t width, std::size_t height, bool organised, const PreprocessParams& params)
{
  if (!organised)
    return std::max<std::size_t>(1, ceilDiv(width, params.max_sampled_points));
  std::size_t stride = static_cast<std::size_t>(params.pixel_stride);
  const std::size_t sampled = ceilDiv(height, stride) * ceilDiv(width, stride);
  if (sampled <= params.max_sampled_points)
    return stride;
  // sqrt(width * height / max) undershoots the answer by at most a few steps (the rounding up).
  const double ratio = static_cast<double>(width) * static_cast<double>(height) / params.max_sampled_points;
  stride = std::max(stride, static_cast<std::size_t>(std::sqrt(ratio)));
  while (ceilDiv(height, stride) * ceilDiv(width, stride) > params.max_sampled_points)
    ++stride;
  return stride;
}

std::string validateView(const RawCloudView& view)
{
  if (view.width == 0 || view.height == 0)
    return {};  // empty: reported as such by the common path
  if (!view.data)
    return "malformed cloud: no data";
  const std::uint32_t last_offset = std::max({ view.x_offset, view.y_offset, view.z_offset });
  if (view.point_step < last_offset + sizeof(float))
    return "malformed cloud: point_step too small for the x, y, z offsets";
  if (static_cast<std::size_t>(view.point_step) * view.width > view.row_step)
    return "malformed cloud: row_step smaller than width * point_step";
  if (static_cast<std::size_t>(view.row_step) * view.height > view.size_bytes)
    return "malformed cloud: data shorter than height * row_step";
  return {};
}

// pcl::VoxelGrid (uninstrumented) casts coordinate / leaf to int, multiplies the three voxel
// counts in 64 bits and sums each voxel's points in float: with points near 1e38 m (garbage
// bytes read as floats, an unbounded reach_m) or a leaf of 1e-38 m the casts and sums overflow
// and a cloud marked dense came out with inf coordinates (fuzzing,
// test/fuzz/corpus/cloud_preprocess/crash_voxel_grid_overflow). "" when it is safe.
std::string voxelGridProblem(const CloudXYZ& points, double leaf_m)
{
  Eigen::Array3d lo = Eigen::Array3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const auto& p : points.points)
  {
    lo = lo.min(p.getArray3fMap().cast<double>());
    hi = hi.max(p.getArray3fMap().cast<double>());
  }
  const double farthest_m = std::max(lo.abs().maxCoeff(), hi.abs().maxCoeff());
  const double voxels = (((hi - lo) / leaf_m).floor() + 1.0).prod();
  constexpr double kIntMax = static_cast<double>(std::numeric_limits<std::int32_t>::max());
  // 1e30 m keeps the float sum of any voxel's points (< 2^31 of them) finite.
  if (farthest_m / leaf_m >= kIntMax || farthest_m > 1e30 || voxels > kIntMax)
  {
    std::ostringstream why;
    why << "leaf_size_m " << leaf_m << " cannot voxelise points up to " << farthest_m
        << " m from the origin: more voxels or a larger voxel index than pcl::VoxelGrid's int holds";
    return why.str();
  }
  return {};
}

// One pass over the organised cloud: every finite pixel (every pixel_stride-th row and column)
// is transformed once and kept if it is within reach. Doing the reach test after the transform
// (rather than a crop in the camera frame) keeps the filter exact for 12 flops per point.
template <typename Source>
PreprocessResult preprocessImpl(const Source& raw, std::uint64_t stamp, const Eigen::Isometry3f& camera_to_base,
                                const PreprocessParams& params)
{
  PreprocessResult result;
  result.input_points = raw.size();
  auto fail = [&result](const std::string& why) {
    result.ok = false;
    result.reason = why;
    result.cloud.reset();
    return result;
  };
  if (const std::string bad = validateParams(params); !bad.empty())
    return fail("invalid parameters: " + bad);
  if (!camera_to_base.matrix().allFinite())
    return fail("camera_to_base transform is not finite");
  if (raw.size() == 0)
    return fail("empty cloud (0 points)");
  if (raw.size() > params.max_input_points)
  {
    std::ostringstream why;
    why << "cloud too large: " << raw.size() << " points exceeds max_input_points " << params.max_input_points;
    return fail(why.str());
  }
  const std::size_t width = raw.width();
  const std::size_t height = raw.height();
  const std::size_t stride = samplingStride(width, height, raw.organised(), params);
  const std::size_t row_stride = raw.organised() ? stride : 1;
  result.sampling_stride = stride;
  result.downsampled = stride > (raw.organised() ? static_cast<std::size_t>(params.pixel_stride) : 1);

  const Eigen::Matrix3f rotation = camera_to_base.linear();
  const Eigen::Vector3f translation = camera_to_base.translation();
  const float reach_sq = static_cast<float>(params.reach_m * params.reach_m);
  const float min_z = static_cast<float>(std::max(params.min_z_m, -1e30));
  const float max_z = static_cast<float>(std::min(params.max_z_m, 1e30));

  auto in_reach = std::make_shared<CloudXYZ>();
  const std::size_t sampled = ceilDiv(height, row_stride) * ceilDiv(width, stride);
  in_reach->reserve(sampled);
  // Only the sampled pixels are read (a quarter of them with stride 2); a frame whose sampled
  // pixels are all invalid is useless anyway.
  for (std::size_t row = 0; row < height; row += row_stride)
  {
    for (std::size_t col = 0; col < width; col += stride)
    {
      const Eigen::Vector3f p = raw.at(row, col);
      if (!p.allFinite())
      {
        if (std::isinf(p.x()) || std::isinf(p.y()) || std::isinf(p.z()))
          ++result.infinite_points;
        continue;
      }
      ++result.finite_points;
      const Eigen::Vector3f q = rotation * p + translation;
      // A finite point can still overflow in the transform (garbage bytes read as floats near
      // 3e38 in a malformed cloud): its NaN failed every ">" test below and was kept in a cloud
      // marked dense (fuzzing). Such a point is beyond any reach.
      if (!q.allFinite())
        continue;
      if ((q - params.reach_centre_m).squaredNorm() > reach_sq || q.z() < min_z || q.z() > max_z)
        continue;
      in_reach->push_back(PointXYZ(q.x(), q.y(), q.z()));
    }
  }
  if (result.finite_points == 0)
  {
    std::ostringstream why;
    why << "no finite point among " << sampled << " sampled of " << raw.size() << " (" << result.infinite_points
        << " infinite, " << sampled - result.infinite_points << " NaN)";
    return fail(why.str());
  }
  result.in_reach_points = in_reach->size();
  if (in_reach->empty())
  {
    std::ostringstream why;
    why << "no point within reach: " << result.finite_points << " finite points, none within reach_m "
        << params.reach_m << " of the arm base (and within the height band)";
    return fail(why.str());
  }

  CloudXYZ::Ptr output;
  const Stopwatch voxel_watch;
  if (params.leaf_size_m > 0.0)
  {
    if (const std::string bad = voxelGridProblem(*in_reach, params.leaf_size_m); !bad.empty())
      return fail(bad);
    output = std::make_shared<CloudXYZ>();
    pcl::VoxelGrid<PointXYZ> voxel_grid;
    voxel_grid.setInputCloud(in_reach);
    const float leaf = static_cast<float>(params.leaf_size_m);
    voxel_grid.setLeafSize(leaf, leaf, leaf);
    voxel_grid.filter(*output);
  }
  else
  {
    output = in_reach;
  }
  result.voxel_time_s = voxel_watch.elapsedSeconds();
  output->is_dense = true;
  output->sensor_origin_ = Eigen::Vector4f(translation.x(), translation.y(), translation.z(), 0.0f);
  output->sensor_orientation_ = Eigen::Quaternionf(rotation);
  output->header.stamp = stamp;
  result.cloud = output;
  result.ok = true;
  std::ostringstream note;
  if (result.downsampled)
  {
    note << "down-sampled: " << raw.size() << " points would give more than max_sampled_points "
         << params.max_sampled_points << " at pixel_stride " << params.pixel_stride << ", reading every " << stride
         << (raw.organised() ? "-th row and column" : "-th point");
  }
  if (result.infinite_points > 0)
    note << (result.downsampled ? "; " : "") << result.infinite_points << " points with infinite coordinates dropped";
  result.reason = note.str();
  return result;
}
}  // namespace

PreprocessResult preprocessCloud(const pcl::PointCloud<pcl::PointXYZRGB>& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params)
{
  return preprocessImpl(PclSource<pcl::PointXYZRGB>(raw), raw.header.stamp, camera_to_base, params);
}

PreprocessResult preprocessCloud(const CloudXYZ& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params)
{
  return preprocessImpl(PclSource<PointXYZ>(raw), raw.header.stamp, camera_to_base, params);
}

PreprocessResult preprocessCloud(const RawCloudView& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params)
{
  if (const std::string bad = validateView(raw); !bad.empty())
  {
    PreprocessResult result;
    result.input_points = static_cast<std::size_t>(raw.width) * raw.height;
    result.reason = bad;
    return result;
  }
  return preprocessImpl(RawSource(raw), 0, camera_to_base, params);
}

}  // namespace fast_grasp
