// libFuzzer target: the cloud checks and preprocessing on arbitrary clouds: the nodelet's
// in-place PointCloud2 path (RawCloudView: any width, height, strides, x/y/z offsets, buffer
// size) and the pcl::PointCloud paths (checkCloud, preprocessCloud), with NaN, inf and denormal
// coordinates, arbitrary camera transforms and parameters.
//
// Layout: u16 width, u16 height, u16 point_step, u32 row_step, u16 x/y/z offsets,
//         u8 pixel_stride, f32 leaf_size_m, f32 reach_m, f32 min_z_m, f32 max_z_m,
//         u32 max_input_points, 7 x f32 camera pose (translation, quaternion w x y z; a zero
//         quaternion is used as is), then the data buffer (the rest).
#include "fuzz_input.h"

#include "fast_grasp/perception/cloud_checks.h"
#include "fast_grasp/perception/cloud_preprocess.h"

#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>

using namespace fast_grasp;

namespace
{
template <typename PointT>
void checkPclPaths(const RawCloudView& raw, const Eigen::Isometry3f& pose, const PreprocessParams& params)
{
  // The same bytes as a pcl cloud: points read every 16 bytes, width/height as declared (they may
  // disagree with the point count: checkCloud must say so).
  auto cloud = std::make_shared<pcl::PointCloud<PointT>>();
  const std::size_t n = std::min<std::size_t>(raw.size_bytes / 16, 20000);
  cloud->resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    float xyz[3];
    std::memcpy(xyz, raw.data + 16 * i, sizeof(xyz));
    cloud->points[i].x = xyz[0];
    cloud->points[i].y = xyz[1];
    cloud->points[i].z = xyz[2];
  }
  cloud->width = raw.width;
  cloud->height = raw.height;
  const CloudCheck check = checkCloud<PointT>(cloud, params.max_input_points);
  if (check.ok != check.reason.empty())
    __builtin_trap();
  if (check.ok && cloud->width * cloud->height == cloud->size())
  {
    const PreprocessResult result = preprocessCloud(*cloud, pose, params);
    if (result.ok && !result.cloud)
      __builtin_trap();
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fuzz::FuzzInput in(data, size);
  RawCloudView raw;
  raw.width = in.read<std::uint16_t>();
  raw.height = in.read<std::uint16_t>();
  raw.point_step = in.read<std::uint16_t>();
  raw.row_step = in.read<std::uint32_t>();
  raw.x_offset = in.read<std::uint16_t>();
  raw.y_offset = in.read<std::uint16_t>();
  raw.z_offset = in.read<std::uint16_t>();
  PreprocessParams params;
  params.pixel_stride = in.read<std::uint8_t>();
  params.leaf_size_m = in.read<float>();
  params.reach_m = in.read<float>();
  params.min_z_m = in.read<float>();
  params.max_z_m = in.read<float>();
  params.max_input_points = in.read<std::uint32_t>();
  Eigen::Vector3f t;
  for (int k = 0; k < 3; ++k)
    t[k] = in.read<float>();
  Eigen::Quaternionf q;
  q.w() = in.read<float>();
  q.x() = in.read<float>();
  q.y() = in.read<float>();
  q.z() = in.read<float>();
  if (q.norm() > 1e-6f && std::isfinite(q.norm()))
    q.normalize();
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = t;
  // The buffer is copied so ASan sees its true end (libFuzzer's own buffer is exact too, but
  // a copy keeps the view independent of the header bytes).
  const std::vector<std::uint8_t> buffer(in.rest(), in.rest() + in.remaining());
  raw.data = buffer.data();
  raw.size_bytes = buffer.size();
  const PreprocessResult result = preprocessCloud(raw, pose, params);
  if (result.ok && (!result.cloud || result.cloud->empty()))
    __builtin_trap();
  if (result.ok)
    for (const auto& p : result.cloud->points)
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        __builtin_trap();
  checkPclPaths<pcl::PointXYZ>(raw, pose, params);
  checkPclPaths<pcl::PointXYZRGB>(raw, pose, params);
  return 0;
}
