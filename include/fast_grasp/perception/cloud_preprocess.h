// Thesis Ch3.2 step 1 / Ch6.2 step 1, first half: from the raw organised camera cloud to a
// small, NaN-free cloud in the robot base frame (reach filter, voxel grid). ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

namespace fast_grasp
{
struct PreprocessParams
{
  /// Points farther than this from `reach_centre_m` (the arm's shoulder, base frame) cannot
  /// be grasped and are dropped. UR5: 0.85 m.
  double reach_m = 0.85;
  Eigen::Vector3f reach_centre_m = Eigen::Vector3f::Zero();
  /// Optional height band in the base frame (e.g. drop the floor); +-inf disables it.
  double min_z_m = -std::numeric_limits<double>::infinity();
  double max_z_m = std::numeric_limits<double>::infinity();
  /// Voxel-grid leaf; 0 disables down-sampling.
  double leaf_size_m = 0.005;
  /// Use every n-th row and column of an organised cloud. At 0.5-1 m an Xtion pixel covers
  /// 1-2 mm, so with a 5 mm leaf a stride of 2 still leaves several pixels per voxel while
  /// quartering the work (see bench_perception). 1 keeps every pixel.
  int pixel_stride = 2;
  /// Work bound: a cloud that would give more sampled points than this at `pixel_stride` is
  /// read with the smallest coarser stride that fits (every n-th row and column of an organised
  /// cloud, every n-th point of an unorganised one) and the result says so. A 5 MP industrial
  /// camera then costs what a 640x480 one does at stride 1 instead of being refused.
  std::size_t max_sampled_points = 307200;
  /// Larger clouds are rejected before any work: no depth camera gives 50 million points in
  /// one frame; such a cloud is a bug upstream (e.g. an accumulated map), not a view.
  std::size_t max_input_points = 50000000;
};

/// Read-only view of packed float32 x, y, z points in a byte buffer (host byte order), e.g. the
/// data of a sensor_msgs/PointCloud2: the raw camera buffer is filtered in place, without first
/// converting the whole frame to a pcl::PointCloud (a 640x480 frame is ~5 MB).
struct RawCloudView
{
  const std::uint8_t* data = nullptr;
  std::size_t size_bytes = 0;  // must hold height * row_step bytes
  std::uint32_t width = 0;
  std::uint32_t height = 0;  // 1 for unorganised clouds
  std::uint32_t point_step = 0;
  std::uint32_t row_step = 0;
  std::uint32_t x_offset = 0;
  std::uint32_t y_offset = 4;
  std::uint32_t z_offset = 8;
};

struct PreprocessResult
{
  bool ok = false;
  std::string reason;  // why not ok; a note (down-sampled, infinite coordinates dropped) when ok
  /// Base frame, voxelised, dense (no NaN); sensor_origin_ = camera optical centre. Null iff !ok.
  CloudXYZ::Ptr cloud;
  std::size_t input_points = 0;
  // Counts over the pixels sampled by pixel_stride (all points of an unorganised cloud).
  std::size_t finite_points = 0;    // finite x, y, z
  std::size_t infinite_points = 0;  // at least one +-inf coordinate (a driver bug, not "no return")
  std::size_t in_reach_points = 0;  // finite, inside reach and height band
  std::size_t sampling_stride = 0;  // rows/columns (points if unorganised) actually stepped
  bool downsampled = false;         // sampling_stride was raised above pixel_stride (see reason)
  double voxel_time_s = 0.0;        // of the total, the voxel grid (bench_perception reports it)
};

/// Drops non-finite points, transforms each remaining point once into the base frame,
/// keeps those within reach, voxelises. `camera_to_base` maps camera coordinates to base
/// coordinates; its translation becomes the output's sensor_origin_. Never throws on bad
/// input: returns ok = false with a reason (empty, all NaN, too large, nothing in reach, bad params).
PreprocessResult preprocessCloud(const pcl::PointCloud<pcl::PointXYZRGB>& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params);

/// Same, for clouds without colour.
PreprocessResult preprocessCloud(const CloudXYZ& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params);

/// Same, straight from a raw buffer (the nodelet passes the PointCloud2 data). A view whose
/// offsets, steps or size do not fit gives ok = false with the reason.
PreprocessResult preprocessCloud(const RawCloudView& raw, const Eigen::Isometry3f& camera_to_base,
                                 const PreprocessParams& params);

}  // namespace fast_grasp
