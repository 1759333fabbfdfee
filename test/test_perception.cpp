// Perception core on analytic scenes: a sphere's normals point outward, RANSAC recovers a
// known tilted table under a box, two objects 20 cm apart give two clusters, the reach
// filter and the voxel grid behave as computed by hand, and bad input returns a reason.
#include "fast_grasp/perception/cloud_preprocess.h"
#include "fast_grasp/perception/cluster_groups.h"
#include "fast_grasp/perception/grid_clusters.h"
#include "fast_grasp/perception/normal_estimation.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <gtest/gtest.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

using namespace fast_grasp;

namespace
{
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

double angleBetween(const Eigen::Vector3f& a, const Eigen::Vector3f& b)
{
  return std::acos(std::clamp(static_cast<double>(a.normalized().dot(b.normalized())), -1.0, 1.0));
}

/// Camera at `eye` looking at `target`, pinhole with `pixels` x `pixels` rays of `pixel_rad`
/// spacing; returns where the rays first hit a sphere, plus axial noise (along the ray).
CloudXYZ::Ptr raycastSphere(const Eigen::Vector3f& eye, const Eigen::Vector3f& centre, float radius, int pixels,
                            float pixel_rad, float noise_m, unsigned seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, noise_m);
  const Eigen::Vector3f forward = (centre - eye).normalized();
  const Eigen::Vector3f right = forward.unitOrthogonal();
  const Eigen::Vector3f down = forward.cross(right);
  auto cloud = std::make_shared<CloudXYZ>();
  for (int r = 0; r < pixels; ++r)
    for (int c = 0; c < pixels; ++c)
    {
      const Eigen::Vector3f ray =
          (forward + right * std::tan((c - pixels / 2) * pixel_rad) + down * std::tan((r - pixels / 2) * pixel_rad))
              .normalized();
      // |eye + t ray - centre|^2 = radius^2, nearest root.
      const Eigen::Vector3f oc = eye - centre;
      const float b = ray.dot(oc);
      const float disc = b * b - (oc.squaredNorm() - radius * radius);
      if (disc < 0.0f)
        continue;
      const float t = -b - std::sqrt(disc) + noise(rng);
      const Eigen::Vector3f p = eye + t * ray;
      cloud->push_back(PointXYZ(p.x(), p.y(), p.z()));
    }
  return cloud;
}

/// Grid samples of the plane through `origin` spanned by `u`, `v` (unit), `step` apart.
void addPatch(CloudXYZ& cloud, const Eigen::Vector3f& origin, const Eigen::Vector3f& u, const Eigen::Vector3f& v,
              float size_u, float size_v, float step, float noise_m, std::mt19937& rng)
{
  std::normal_distribution<float> noise(0.0f, noise_m);
  const Eigen::Vector3f normal = u.cross(v).normalized();
  for (float a = 0.5f * step; a < size_u; a += step)
    for (float b = 0.5f * step; b < size_v; b += step)
    {
      const Eigen::Vector3f p = origin + a * u + b * v + (noise_m > 0.0f ? noise(rng) : 0.0f) * normal;
      cloud.push_back(PointXYZ(p.x(), p.y(), p.z()));
    }
}

/// Axis-aligned box standing on z = `floor_z` (top and four sides sampled), footprint centred at `centre_xy`.
/// The faces of an axis-aligned box (no bottom) that a camera at `eye` sees, as one view does:
/// the concave-crease split orients normals toward the camera, so a face turned away from it
/// would read as folded inward.
void addBox(CloudXYZ& cloud, const Eigen::Vector2f& centre_xy, float floor_z, const Eigen::Vector3f& size, float step,
            std::mt19937& rng, const Eigen::Vector3f& eye)
{
  const Eigen::Vector3f lo(centre_xy.x() - size.x() / 2, centre_xy.y() - size.y() / 2, floor_z);
  const Eigen::Vector3f ex = Eigen::Vector3f::UnitX(), ey = Eigen::Vector3f::UnitY(), ez = Eigen::Vector3f::UnitZ();
  const Eigen::Vector3f centre = lo + size / 2;
  auto face = [&](const Eigen::Vector3f& corner, const Eigen::Vector3f& u, const Eigen::Vector3f& v, float width,
                  float height, const Eigen::Vector3f& outward) {
    const Eigen::Vector3f face_centre = centre + outward.cwiseProduct(size / 2);
    if ((eye - face_centre).dot(outward) > 0.0f)
      addPatch(cloud, corner, u, v, width, height, step, 0.0005f, rng);
  };
  face(lo + Eigen::Vector3f(0, 0, size.z()), ex, ey, size.x(), size.y(), ez);        // top
  face(lo, ex, ez, size.x(), size.z(), -ey);                                          // -y side
  face(lo + Eigen::Vector3f(0, size.y(), 0), ex, ez, size.x(), size.z(), ey);        // +y
  face(lo, ey, ez, size.y(), size.z(), -ex);                                          // -x
  face(lo + Eigen::Vector3f(size.x(), 0, 0), ey, ez, size.y(), size.z(), ex);        // +x
}

/// A camera at `eye` looking at `target` (optical z axis toward it).
void aimCamera(CloudXYZ& cloud, const Eigen::Vector3f& eye, const Eigen::Vector3f& target)
{
  cloud.sensor_origin_ = Eigen::Vector4f(eye.x(), eye.y(), eye.z(), 0.0f);
  cloud.sensor_orientation_ = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), (target - eye).normalized());
}

void finish(CloudXYZ& cloud)
{
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
  cloud.is_dense = true;
}

/// The points of `back` that the camera at `eye` sees past `front`: none of front's points lies
/// within 5 mm of the line of sight, nearer than the point.
CloudXYZ visibleFrom(const Eigen::Vector3f& eye, const CloudXYZ& back, const CloudXYZ& front)
{
  CloudXYZ seen;
  for (const auto& p : back.points)
  {
    const Eigen::Vector3f ray = p.getVector3fMap() - eye;
    const bool hidden = std::any_of(front.points.begin(), front.points.end(), [&](const PointXYZ& o) {
      const float along = (o.getVector3fMap() - eye).dot(ray) / ray.squaredNorm();
      return along > 0.0f && along < 1.0f && (eye + along * ray - o.getVector3fMap()).norm() < 0.005f;
    });
    if (!hidden)
      seen.push_back(p);
  }
  return seen;
}
}  // namespace

// ------------------------------------------------------------------------------------------
// Preprocessing

TEST(CloudPreprocess, ReachFilterDropsPointsBeyondReach)
{
  // Camera 1 m above the base looking down (optical z = base -z); points at known base distances.
  Eigen::Isometry3f camera_to_base = Eigen::Isometry3f::Identity();
  camera_to_base.translation() = Eigen::Vector3f(0, 0, 1.0f);
  camera_to_base.linear() = Eigen::AngleAxisf(static_cast<float>(M_PI), Eigen::Vector3f::UnitX()).toRotationMatrix();
  pcl::PointCloud<pcl::PointXYZRGB> raw;
  // Base-frame targets on z = 0 at x = 0.5, 0.84, 0.86, 1.2: camera coords (x, -y, 1 - z).
  for (const float x : { 0.5f, 0.84f, 0.86f, 1.2f })
  {
    pcl::PointXYZRGB p;
    p.x = x;
    p.y = 0.0f;
    p.z = 1.0f;
    raw.push_back(p);
  }
  PreprocessParams params;
  params.leaf_size_m = 0.0;
  const PreprocessResult result = preprocessCloud(raw, camera_to_base, params);
  ASSERT_TRUE(result.ok) << result.reason;
  ASSERT_EQ(result.cloud->size(), 2u);
  EXPECT_NEAR(result.cloud->points[0].x, 0.5f, 1e-5f);
  EXPECT_NEAR(result.cloud->points[0].z, 0.0f, 1e-5f);
  EXPECT_NEAR(result.cloud->points[1].x, 0.84f, 1e-5f);
  EXPECT_EQ(result.in_reach_points, 2u);
  // The sensor origin is the camera's optical centre in the base frame.
  EXPECT_TRUE(result.cloud->sensor_origin_.head<3>().isApprox(Eigen::Vector3f(0, 0, 1.0f)));
}

TEST(CloudPreprocess, VoxelGridReducesDensityToOnePointPerLeaf)
{
  // 100 x 100 points 1 mm apart, offset half a millimetre from the 1 cm voxel boundaries:
  // exactly 10 x 10 voxels, each the centroid of 100 points.
  pcl::PointCloud<pcl::PointXYZRGB> raw;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j)
    {
      pcl::PointXYZRGB p;
      p.x = 0.3005f + 0.001f * i;
      p.y = 0.0005f + 0.001f * j;
      p.z = 0.0f;
      raw.push_back(p);
    }
  PreprocessParams params;
  params.leaf_size_m = 0.01;
  const PreprocessResult result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(result.ok) << result.reason;
  EXPECT_EQ(result.in_reach_points, 10000u);
  ASSERT_EQ(result.cloud->size(), 100u);
  for (const auto& p : result.cloud->points)
  {
    // Voxel centroids sit at the voxel centres: 0.305, 0.315, ...
    EXPECT_NEAR(std::fmod(p.x + 1e-4f, 0.01f), 0.005f + 1e-4f, 1e-4f);
    EXPECT_NEAR(std::fmod(p.y + 1e-4f, 0.01f), 0.005f + 1e-4f, 1e-4f);
  }
}

TEST(CloudPreprocess, OrganisedStrideSamplesEveryOtherPixel)
{
  pcl::PointCloud<pcl::PointXYZRGB> raw(8, 6);  // organised, all at (0.5, 0, 0)
  for (auto& p : raw.points)
  {
    p.x = 0.5f;
    p.y = 0.0f;
    p.z = 0.0f;
  }
  PreprocessParams params;
  params.leaf_size_m = 0.0;
  params.pixel_stride = 2;
  PreprocessResult result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(result.ok);
  EXPECT_EQ(result.cloud->size(), 4u * 3u);
  params.pixel_stride = 1;
  result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  EXPECT_EQ(result.cloud->size(), 48u);
}

TEST(CloudPreprocess, OversizeOrganisedCloudIsReadWithACoarserStride)
{
  // 50 x 40 = 2000 pixels, all in reach; at most 100 may be sampled. Stride 2 gives 25 x 20 =
  // 500, too many; the smallest stride that fits is 5 (10 x 8 = 80; 4 gives 13 x 10 = 130).
  pcl::PointCloud<pcl::PointXYZRGB> raw(50, 40);
  for (std::size_t i = 0; i < raw.size(); ++i)
  {
    raw.points[i].x = 0.3f + 0.001f * static_cast<float>(i % 50);
    raw.points[i].y = 0.001f * static_cast<float>(i / 50);
    raw.points[i].z = 0.0f;
  }
  PreprocessParams params;
  params.leaf_size_m = 0.0;
  params.pixel_stride = 2;
  params.max_sampled_points = 100;
  PreprocessResult result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(result.ok) << result.reason;
  EXPECT_TRUE(result.downsampled);
  EXPECT_EQ(result.sampling_stride, 5u);
  EXPECT_EQ(result.cloud->size(), 80u);
  EXPECT_EQ(result.finite_points, 80u);
  EXPECT_NE(result.reason.find("down-sampled"), std::string::npos) << result.reason;
  // Pixel (5, 10) is sampled, (4, 10) is not.
  const auto has = [&](float x, float y) {
    return std::any_of(result.cloud->begin(), result.cloud->end(),
                       [&](const PointXYZ& p) { return std::abs(p.x - x) < 1e-6f && std::abs(p.y - y) < 1e-6f; });
  };
  EXPECT_TRUE(has(0.305f, 0.010f));
  EXPECT_FALSE(has(0.304f, 0.010f));

  // Within the bound nothing changes and nothing is noted.
  params.max_sampled_points = 500;
  result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(result.ok);
  EXPECT_FALSE(result.downsampled);
  EXPECT_EQ(result.sampling_stride, 2u);
  EXPECT_EQ(result.cloud->size(), 500u);
  EXPECT_TRUE(result.reason.empty()) << result.reason;
}

TEST(CloudPreprocess, OversizeUnorganisedCloudKeepsEveryNthPoint)
{
  CloudXYZ raw;
  for (int i = 0; i < 1000; ++i)
    raw.push_back(PointXYZ(0.3f + 0.0001f * static_cast<float>(i), 0.0f, 0.0f));
  PreprocessParams params;
  params.leaf_size_m = 0.0;
  params.max_sampled_points = 300;  // 1000 / 300 -> every 4th point: 250
  const PreprocessResult result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(result.ok) << result.reason;
  EXPECT_TRUE(result.downsampled);
  EXPECT_EQ(result.sampling_stride, 4u);
  ASSERT_EQ(result.cloud->size(), 250u);
  EXPECT_NEAR(result.cloud->points[1].x, 0.3f + 0.0004f, 1e-6f);
}

TEST(CloudPreprocess, RawBufferViewMatchesThePclPath)
{
  // A 6 x 4 organised cloud packed as x y z rgb (16 bytes a point), one NaN pixel.
  pcl::PointCloud<pcl::PointXYZRGB> cloud(6, 4);
  std::vector<std::uint8_t> buffer(cloud.size() * 16, 0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
  {
    const float xyz[3] = { 0.3f + 0.01f * static_cast<float>(i % 6), 0.02f * static_cast<float>(i / 6),
                           i == 7 ? kNaN : 0.1f };
    cloud.points[i].x = xyz[0];
    cloud.points[i].y = xyz[1];
    cloud.points[i].z = xyz[2];
    std::memcpy(&buffer[i * 16], xyz, sizeof(xyz));
  }
  RawCloudView view;
  view.data = buffer.data();
  view.size_bytes = buffer.size();
  view.width = 6;
  view.height = 4;
  view.point_step = 16;
  view.row_step = 6 * 16;
  PreprocessParams params;
  params.leaf_size_m = 0.0;
  params.pixel_stride = 1;
  const PreprocessResult from_view = preprocessCloud(view, Eigen::Isometry3f::Identity(), params);
  const PreprocessResult from_pcl = preprocessCloud(cloud, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(from_view.ok) << from_view.reason;
  ASSERT_EQ(from_view.cloud->size(), 23u);
  ASSERT_EQ(from_pcl.cloud->size(), 23u);
  for (std::size_t i = 0; i < 23; ++i)
    EXPECT_TRUE(from_view.cloud->points[i].getVector3fMap().isApprox(from_pcl.cloud->points[i].getVector3fMap()));

  RawCloudView short_view = view;
  short_view.size_bytes = buffer.size() - 1;
  PreprocessResult result;
  ASSERT_NO_THROW(result = preprocessCloud(short_view, Eigen::Isometry3f::Identity(), params));
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("malformed"), std::string::npos) << result.reason;
  RawCloudView bad_offsets = view;
  bad_offsets.z_offset = 14;
  EXPECT_FALSE(preprocessCloud(bad_offsets, Eigen::Isometry3f::Identity(), params).ok);
  RawCloudView empty_view;
  EXPECT_NE(preprocessCloud(empty_view, Eigen::Isometry3f::Identity(), params).reason.find("empty"),
            std::string::npos);
}

TEST(CloudPreprocess, PointsWhoseTransformOverflowsAreDropped)
{
  // Garbage bytes read as floats can be near 3.4e38: rotated, such a finite point overflows to
  // inf (or NaN), which passed the reach test when reach_m is effectively unbounded (its square
  // is inf) and ended up in a cloud marked dense (fuzzing; test/fuzz/corpus/cloud_preprocess/).
  CloudXYZ raw;
  raw.push_back(PointXYZ(3e38f, 3e38f, 0.0f));
  raw.push_back(PointXYZ(0.1f, 0.0f, 0.2f));
  PreprocessParams params;
  params.reach_m = 1e30;  // "no reach limit"
  params.leaf_size_m = 0.0;
  const Eigen::Isometry3f rotated(Eigen::AngleAxisf(0.785398f, Eigen::Vector3f::UnitZ()));
  const PreprocessResult result = preprocessCloud(raw, rotated, params);
  ASSERT_TRUE(result.ok) << result.reason;
  ASSERT_EQ(result.cloud->size(), 1u);
  EXPECT_TRUE(result.cloud->points[0].getVector3fMap().allFinite());
}

TEST(CloudPreprocess, PointsTheVoxelGridCannotIndexAreAReasonNotInf)
{
  // With reach_m unbounded, points 1e37 m out reach pcl::VoxelGrid, whose int voxel indices
  // and float voxel sums overflow: a "dense" cloud with inf coordinates came out (fuzzing;
  // test/fuzz/corpus/cloud_preprocess/crash_voxel_grid_overflow).
  CloudXYZ raw;
  raw.push_back(PointXYZ(1e37f, 0.0f, 0.1f));
  raw.push_back(PointXYZ(-1e37f, 0.0f, 0.1f));
  raw.push_back(PointXYZ(0.1f, 0.0f, 0.2f));
  PreprocessParams params;
  params.reach_m = 1e30;  // "no reach limit"
  params.leaf_size_m = 0.005;
  const PreprocessResult result = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("cannot voxelise points up to 1e+37 m"), std::string::npos) << result.reason;
  // The same cloud without the far points voxelises as before.
  raw.points.erase(raw.points.begin(), raw.points.begin() + 2);
  raw.width = 1;
  const PreprocessResult near = preprocessCloud(raw, Eigen::Isometry3f::Identity(), params);
  ASSERT_TRUE(near.ok) << near.reason;
  EXPECT_EQ(near.cloud->size(), 1u);
}

TEST(CloudPreprocess, BadInputGivesReasonNotThrow)
{
  PreprocessParams params;
  params.pixel_stride = 1;  // count every pixel
  const Eigen::Isometry3f identity = Eigen::Isometry3f::Identity();
  pcl::PointCloud<pcl::PointXYZRGB> raw;
  PreprocessResult result;
  ASSERT_NO_THROW(result = preprocessCloud(raw, identity, params));
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("empty"), std::string::npos) << result.reason;
  EXPECT_FALSE(result.cloud);

  raw = pcl::PointCloud<pcl::PointXYZRGB>(64, 48);
  for (auto& p : raw.points)
    p.x = p.y = p.z = kNaN;
  ASSERT_NO_THROW(result = preprocessCloud(raw, identity, params));
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("no finite point"), std::string::npos) << result.reason;

  for (auto& p : raw.points)
    p.x = p.y = p.z = kInf;
  ASSERT_NO_THROW(result = preprocessCloud(raw, identity, params));
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.infinite_points, raw.size());

  // Some infinite points among good ones: processed, the note says what was dropped.
  for (auto& p : raw.points)
  {
    p.x = 0.4f;
    p.y = 0.1f;
    p.z = 0.0f;
  }
  raw.points[5].z = -kInf;
  raw.points[7].x = kInf;
  ASSERT_NO_THROW(result = preprocessCloud(raw, identity, params));
  ASSERT_TRUE(result.ok) << result.reason;
  EXPECT_EQ(result.infinite_points, 2u);
  EXPECT_NE(result.reason.find("infinite"), std::string::npos);
  EXPECT_TRUE(result.cloud->is_dense);

  // Everything beyond reach.
  for (auto& p : raw.points)
    p.x = 2.0f;
  result = preprocessCloud(raw, identity, params);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("reach"), std::string::npos) << result.reason;

  // Too large, bad parameters, non-finite transform.
  PreprocessParams small = params;
  small.max_input_points = 100;
  result = preprocessCloud(raw, identity, small);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("too large"), std::string::npos) << result.reason;
  PreprocessParams bad = params;
  bad.leaf_size_m = -1.0;
  EXPECT_FALSE(preprocessCloud(raw, identity, bad).ok);
  Eigen::Isometry3f broken = identity;
  broken.translation().x() = kNaN;
  EXPECT_FALSE(preprocessCloud(raw, broken, params).ok);
}

// ------------------------------------------------------------------------------------------
// Euclidean clusters on a grid

namespace
{
/// A partition as a set of sorted index lists (order of clusters ignored).
std::set<std::vector<pcl::index_t>> asPartition(const std::vector<pcl::PointIndices>& clusters)
{
  std::set<std::vector<pcl::index_t>> out;
  for (const auto& c : clusters)
  {
    std::vector<pcl::index_t> sorted(c.indices.begin(), c.indices.end());
    std::sort(sorted.begin(), sorted.end());
    out.insert(sorted);
  }
  return out;
}
}  // namespace

TEST(ClusterFootprints, HeightsAboveATiltedTableAndHorizontalCoordinatesKeepDistances)
{
  // The plane 2 (0, sin t, cos t) . p + 2 * (-0.1) = 0 (not unit): a table 10 cm along its
  // normal from the origin, tilted t = 0.3 rad. A point 5 cm above it along the normal has height
  // 0.05; two points on one vertical line of the table share their horizontal coordinates, and
  // two points 4 cm apart within the table are 4 cm apart in them.
  const float t = 0.3f;
  const Eigen::Vector3f up(0.0f, std::sin(t), std::cos(t));
  const auto table = tableAxes(Eigen::Vector4f(2.0f * up.x(), 2.0f * up.y(), 2.0f * up.z(), -0.2f));
  ASSERT_TRUE(table.has_value());
  const Eigen::Vector3f on_table = 0.1f * up + Eigen::Vector3f(0.02f, 0.0f, 0.0f);
  EXPECT_NEAR(table->height(on_table), 0.0f, 1e-6f);
  EXPECT_NEAR(table->height(on_table + 0.05f * up), 0.05f, 1e-6f);
  EXPECT_NEAR((table->horizontal(on_table + 0.05f * up) - table->horizontal(on_table)).norm(), 0.0f, 1e-6f);
  const Eigen::Vector3f along_table = up.unitOrthogonal().cross(up).normalized();
  EXPECT_NEAR((table->horizontal(on_table + 0.04f * along_table) - table->horizontal(on_table)).norm(), 0.04f, 1e-6f);
  EXPECT_FALSE(tableAxes(Eigen::Vector4f(0.0f, 0.0f, 0.0f, 1.0f)).has_value());
  EXPECT_FALSE(tableAxes(Eigen::Vector4f(std::nanf(""), 0.0f, 1.0f, 0.0f)).has_value());

  CloudXYZ cloud;
  for (const Eigen::Vector3f& p : { Eigen::Vector3f(on_table + 0.01f * up),
                                    Eigen::Vector3f(on_table + 0.03f * up + 0.02f * along_table),
                                    Eigen::Vector3f(on_table + 0.08f * up) })
    cloud.push_back(PointXYZ(p.x(), p.y(), p.z()));
  std::vector<pcl::PointIndices> clusters(2);
  clusters[0].indices = { 0, 1 };
  const auto footprints = clusterFootprints(cloud, clusters, *table);
  ASSERT_EQ(footprints.size(), 2u);
  EXPECT_NEAR(footprints[0].low, 0.01f, 1e-6f);
  EXPECT_NEAR(footprints[0].top, 0.03f, 1e-6f);
  ASSERT_EQ(footprints[0].points.size(), 2u);
  EXPECT_NEAR((footprints[0].mean - table->horizontal(on_table + 0.01f * along_table)).norm(), 0.0f, 1e-6f);
  EXPECT_TRUE(footprints[1].points.empty());
  EXPECT_TRUE(std::isinf(footprints[1].low) && footprints[1].low > 0.0f);
}

TEST(GridClusters, ChainsCloserThanTheToleranceAreOneClusterAndAGapSplitsThem)
{
  // Five points 1.9 cm apart in a row (a chain within the 2 cm tolerance although its ends are
  // 7.6 cm apart), then a 2.1 cm gap, then two more points 1 cm apart; NaN points are skipped.
  CloudXYZ cloud;
  for (const float x : { 0.0f, 0.019f, 0.038f, 0.057f, 0.076f, 0.097f, 0.107f })
    cloud.push_back(PointXYZ(x, 0.3f, 0.1f));
  cloud.push_back(PointXYZ(kNaN, 0.3f, 0.1f));
  pcl::Indices all(cloud.size());
  std::iota(all.begin(), all.end(), 0);
  auto clusters = gridEuclideanClusters(cloud, all, 0.02, 1, 100);
  ASSERT_TRUE(clusters.has_value());
  ASSERT_EQ(clusters->size(), 2u);
  EXPECT_EQ((*clusters)[0].indices, (pcl::Indices{ 0, 1, 2, 3, 4 })) << "largest first";
  EXPECT_EQ((*clusters)[1].indices, (pcl::Indices{ 5, 6 }));
  clusters = gridEuclideanClusters(cloud, all, 0.02, 3, 100);
  ASSERT_TRUE(clusters.has_value());
  EXPECT_EQ(clusters->size(), 1u) << "clusters below min_points are dropped";
  clusters = gridEuclideanClusters(cloud, all, 0.02, 1, 4);
  ASSERT_TRUE(clusters.has_value());
  EXPECT_EQ(clusters->size(), 1u) << "clusters above max_points are dropped";
  EXPECT_FALSE(gridEuclideanClusters(cloud, all, 0.02, 1, 100, 100).has_value()) << "grid too large (14 x 5 x 5 cells): nullopt";
  EXPECT_TRUE(gridEuclideanClusters(cloud, pcl::Indices{}, 0.02, 1, 100)->empty());
  // Finite but far-flung points: no grid (the caller's k-d tree takes them), no overflow.
  cloud.push_back(PointXYZ(1e30f, -1e30f, 3e38f));
  pcl::Indices with_far(cloud.size());
  std::iota(with_far.begin(), with_far.end(), 0);
  EXPECT_FALSE(gridEuclideanClusters(cloud, with_far, 0.02, 1, 100).has_value());
}

TEST(GridClusters, SamePartitionAsPclEuclideanClusterExtraction)
{
  // Random scenes of blobs, sheets and scattered points, some within the tolerance of each
  // other: the grid must find exactly the clusters PCL's k-d tree finds.
  for (unsigned seed = 1; seed <= 20; ++seed)
  {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> where(-0.3f, 0.3f), size(0.005f, 0.08f), unit(0.0f, 1.0f);
    std::normal_distribution<float> spread(0.0f, 1.0f);
    auto cloud = std::make_shared<CloudXYZ>();
    for (int blob = 0; blob < 12; ++blob)
    {
      const Eigen::Vector3f centre(where(rng), where(rng), 0.5f * where(rng));
      const Eigen::Vector3f extent(size(rng), size(rng), size(rng));
      const int n = 5 + static_cast<int>(300.0f * unit(rng));
      for (int i = 0; i < n; ++i)
      {
        const Eigen::Vector3f p = centre + extent.cwiseProduct(Eigen::Vector3f(spread(rng), spread(rng), spread(rng)));
        cloud->push_back(PointXYZ(p.x(), p.y(), p.z()));
      }
    }
    for (int i = 0; i < 200; ++i)
      cloud->push_back(PointXYZ(where(rng), where(rng), where(rng)));
    finish(*cloud);
    auto candidates = std::make_shared<pcl::Indices>();
    for (std::size_t i = 0; i < cloud->size(); i += 1 + (i % 7 == 0 ? 1 : 0))
      candidates->push_back(static_cast<pcl::index_t>(i));
    for (const double tolerance : { 0.01, 0.02, 0.035 })
    {
      auto tree = std::make_shared<pcl::search::KdTree<PointXYZ>>();
      tree->setInputCloud(cloud, candidates);
      pcl::EuclideanClusterExtraction<PointXYZ> clustering;
      clustering.setClusterTolerance(tolerance);
      clustering.setMinClusterSize(10);
      clustering.setMaxClusterSize(100000);
      clustering.setSearchMethod(tree);
      clustering.setInputCloud(cloud);
      clustering.setIndices(candidates);
      std::vector<pcl::PointIndices> expected;
      clustering.extract(expected);
      const auto found = gridEuclideanClusters(*cloud, *candidates, tolerance, 10, 100000);
      ASSERT_TRUE(found.has_value());
      EXPECT_EQ(asPartition(*found), asPartition(expected)) << "seed " << seed << ", tolerance " << tolerance;
      for (std::size_t c = 1; c < found->size(); ++c)
        EXPECT_GE((*found)[c - 1].indices.size(), (*found)[c].indices.size()) << "largest first";
    }
  }
}

// ------------------------------------------------------------------------------------------
// Table segmentation

TEST(TableSegmentation, RansacFindsKnownTiltedPlaneUnderBox)
{
  // Table: 0.6 x 0.6 m, 5 mm grid, 2 mm noise, tilted 3 degrees about x, through (0.3, -0.3, 0.1).
  std::mt19937 rng(7);
  const float tilt = static_cast<float>(3.0 * M_PI / 180.0);
  const Eigen::Vector3f u = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f v(0.0f, std::cos(tilt), std::sin(tilt));
  const Eigen::Vector3f origin(0.3f, -0.3f, 0.1f);
  auto cloud = std::make_shared<CloudXYZ>();
  addPatch(*cloud, origin, u, v, 0.6f, 0.6f, 0.005f, 0.002f, rng);
  const std::size_t table_points = cloud->size();
  // Box on the table near (0.6, 0): the table height there is 0.1 + 0.3 tan(tilt) ~ 0.1157;
  // the box stands on z = 0.13 (a small gap keeps the test about the plane, not contact).
  const Eigen::Vector3f eye(0.3f, -0.3f, 0.8f);
  addBox(*cloud, Eigen::Vector2f(0.6f, 0.0f), 0.13f, Eigen::Vector3f(0.06f, 0.08f, 0.12f), 0.005f, rng, eye);
  const std::size_t box_points = cloud->size() - table_points;
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.6f, 0.0f, 0.15f));

  const TableSegmentationResult result = segmentTable(cloud, TableSegmentationParams());
  ASSERT_TRUE(result.ok()) << result.reason;
  const Eigen::Vector3f true_normal = u.cross(v).normalized();
  const float true_d = -true_normal.dot(origin);
  EXPECT_LT(angleBetween(result.plane.head<3>(), true_normal), 1.0 * M_PI / 180.0);
  EXPECT_GT(result.plane.z(), 0.0f) << "normal must point up";
  // Offset compared where the object stands (0.6, 0, table height).
  const Eigen::Vector3f probe(0.6f, 0.0f, (-true_d - true_normal.x() * 0.6f) / true_normal.z());
  EXPECT_NEAR(result.plane.head<3>().dot(probe) + result.plane[3], 0.0f, 0.005f);
  EXPECT_NEAR(static_cast<double>(result.table->size()), static_cast<double>(table_points), 0.02 * table_points);
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_EQ(result.object->size(), box_points);
  EXPECT_EQ(result.scene->size(), cloud->size() - box_points);
  EXPECT_NEAR(result.object_max.z(), 0.25f, 0.003f);
  EXPECT_NEAR(result.object_min.x(), 0.57f, 0.003f);
  EXPECT_NEAR(result.object_max.x(), 0.63f, 0.003f);
}

TEST(TableSegmentation, TwoObjectsTwentyCentimetresApartAreTwoClusters)
{
  std::mt19937 rng(3);
  auto cloud = std::make_shared<CloudXYZ>();
  addPatch(*cloud, Eigen::Vector3f(0.2f, -0.4f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.8f,
           0.005f, 0.001f, rng);
  // Near box (small) at x = 0.4, far box (large) 20 cm away at x = 0.6.
  const std::size_t before_near = cloud->size();
  const Eigen::Vector3f eye(0.5f, -0.3f, 0.9f);
  addBox(*cloud, Eigen::Vector2f(0.4f, 0.0f), 0.0f, Eigen::Vector3f(0.05f, 0.05f, 0.08f), 0.005f, rng, eye);
  const std::size_t near_points = cloud->size() - before_near;
  const std::size_t before_far = cloud->size();
  addBox(*cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.08f, 0.08f, 0.15f), 0.005f, rng, eye);
  const std::size_t far_points = cloud->size() - before_far;
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.5f, 0.0f, 0.0f));
  // Points of each box within 1 cm of the table are table by definition (min_height_above_table_m).
  TableSegmentationParams params;
  params.target = TargetCluster::Nearest;
  TableSegmentationResult result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  ASSERT_EQ(result.clusters.size(), 2u);
  EXPECT_LT(result.object->size(), near_points);
  EXPECT_GT(result.object->size(), near_points * 8 / 10);
  EXPECT_NEAR(result.object_centroid.x(), 0.4f, 0.01f);  // nearest to the base origin

  params.target = TargetCluster::Largest;
  result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.object_centroid.x(), 0.6f, 0.02f);  // seen faces only: off-centre
  EXPECT_GT(result.object->size(), far_points * 8 / 10);

  params.target = TargetCluster::ClosestToPoint;
  params.target_point_m = Eigen::Vector3f(0.65f, 0.05f, 0.1f);
  result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.object_centroid.x(), 0.6f, 0.02f);  // seen faces only: off-centre
  params.target_point_m = Eigen::Vector3f(0.3f, 0.0f, 0.0f);
  result = segmentTable(cloud, params);
  EXPECT_NEAR(result.object_centroid.x(), 0.4f, 0.01f);

  // The camera aimed at the far box picks the far box; aimed at the near one, the near one.
  aimCamera(*cloud, eye, Eigen::Vector3f(0.6f, 0.0f, 0.1f));
  params.target = TargetCluster::CenterOfView;
  result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.object_centroid.x(), 0.6f, 0.02f);  // seen faces only: off-centre
  EXPECT_TRUE(result.object->sensor_origin_.isApprox(cloud->sensor_origin_));
  aimCamera(*cloud, eye, Eigen::Vector3f(0.4f, 0.0f, 0.05f));
  result = segmentTable(cloud, params);
  EXPECT_NEAR(result.object_centroid.x(), 0.4f, 0.01f);

  TargetCluster parsed = TargetCluster::Nearest;
  EXPECT_TRUE(parseTargetCluster("center_of_view", parsed));
  EXPECT_EQ(parsed, TargetCluster::CenterOfView);
  EXPECT_TRUE(parseTargetCluster("largest", parsed));
  EXPECT_EQ(parsed, TargetCluster::Largest);
  EXPECT_FALSE(parseTargetCluster("biggest", parsed));
}

TEST(TableSegmentation, LabelledObjectsGiveTheTargetLabelZeroAndEveryOtherClusterItsOwn)
{
  std::mt19937 rng(5);
  auto cloud = std::make_shared<CloudXYZ>();
  addPatch(*cloud, Eigen::Vector3f(0.2f, -0.4f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.8f,
           0.005f, 0.001f, rng);
  const Eigen::Vector3f eye(0.5f, -0.3f, 0.9f);
  addBox(*cloud, Eigen::Vector2f(0.4f, 0.0f), 0.0f, Eigen::Vector3f(0.05f, 0.05f, 0.08f), 0.005f, rng, eye);
  addBox(*cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.08f, 0.08f, 0.15f), 0.005f, rng, eye);
  addBox(*cloud, Eigen::Vector2f(0.5f, 0.25f), 0.0f, Eigen::Vector3f(0.06f, 0.04f, 0.10f), 0.005f, rng, eye);
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.5f, 0.0f, 0.0f));
  cloud->header.frame_id = "base_link";
  TableSegmentationParams params;
  params.target = TargetCluster::ClosestToPoint;
  params.target_point_m = Eigen::Vector3f(0.6f, 0.0f, 0.1f);  // the tall box is the target
  const TableSegmentationResult result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  ASSERT_EQ(result.clusters.size(), 3u);

  const auto objects = labelledObjects(*cloud, result);
  ASSERT_TRUE(objects);
  EXPECT_EQ(objects->header.frame_id, "base_link");
  EXPECT_TRUE(objects->sensor_origin_.isApprox(cloud->sensor_origin_));
  std::size_t clustered = 0;
  for (const auto& c : result.clusters)
    clustered += c.indices.size();
  ASSERT_EQ(objects->size(), clustered);  // every clustered point once, nothing else
  // Each label's centroid is one box's: 0 the target (x = 0.6), then the other two.
  std::map<std::uint32_t, Eigen::Vector3d> sums;
  std::map<std::uint32_t, int> counts;
  for (const auto& p : objects->points)
  {
    sums[p.label] += p.getVector3fMap().cast<double>();
    ++counts[p.label];
  }
  ASSERT_EQ(counts.size(), 3u);
  std::vector<Eigen::Vector2d> centres;
  for (const auto& [label, sum] : sums)
  {
    EXPECT_LT(label, 3u);
    centres.push_back((sum / counts[label]).head<2>());
  }
  EXPECT_NEAR(centres[0].x(), 0.6, 0.02);
  EXPECT_NEAR(centres[0].y(), 0.0, 0.02);
  EXPECT_EQ(static_cast<std::size_t>(counts[0]), result.object->size());
  const bool near_first = std::abs(centres[1].x() - 0.4) < 0.02;
  const Eigen::Vector2d near_box = near_first ? centres[1] : centres[2];
  const Eigen::Vector2d side_box = near_first ? centres[2] : centres[1];
  EXPECT_NEAR(near_box.x(), 0.4, 0.02);
  EXPECT_NEAR(near_box.y(), 0.0, 0.02);
  EXPECT_NEAR(side_box.x(), 0.5, 0.02);
  EXPECT_NEAR(side_box.y(), 0.25, 0.02);

  // Without a segmentation there is nothing to label.
  TableSegmentationResult failed;
  failed.failure = SegmentationFailure::NoCluster;
  EXPECT_TRUE(labelledObjects(*cloud, failed)->empty());
}

TEST(TableSegmentation, ASixteenMillimetreCubeIsAnObjectAndTableNoiseIsNot)
{
  // A 16 mm dice on a 2 mm-noise table, 5 mm voxels: its top face holds (16 / 5)^2 ~ 10 points
  // and its sides only their upper 6 mm (the lower 1 cm is table by min_height_above_table_m),
  // fewer than the 30 points the cluster minimum once asked for. It must come out as the one
  // cluster, and the table's noise (2 mm sigma: 5 sigma below the 1 cm band) must form none.
  std::mt19937 rng(11);
  auto cloud = std::make_shared<CloudXYZ>();
  addPatch(*cloud, Eigen::Vector3f(0.2f, -0.4f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.8f,
           0.005f, 0.002f, rng);
  const std::size_t table_points = cloud->size();
  const Eigen::Vector3f eye(0.5f, -0.3f, 0.6f);
  addBox(*cloud, Eigen::Vector2f(0.5f, 0.0f), 0.0f, Eigen::Vector3f(0.016f, 0.016f, 0.016f), 0.005f, rng, eye);
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.5f, 0.0f, 0.0f));
  const TableSegmentationParams params;
  const TableSegmentationResult result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_LT(result.object->size(), 30u);
  EXPECT_NEAR(result.object_centroid.x(), 0.5f, 0.01f);
  EXPECT_NEAR(result.object_centroid.y(), 0.0f, 0.01f);
  EXPECT_NEAR(result.object_max.z(), 0.016f, 0.004f);

  auto bare_table = std::make_shared<CloudXYZ>(*cloud);
  bare_table->resize(table_points);
  finish(*bare_table);
  EXPECT_EQ(segmentTable(bare_table, params).failure, SegmentationFailure::NoCluster);
}

TEST(TableSegmentation, StackedPartSplitByAGapIsMergedIntoTheObject)
{
  // A bottle body (0-15 cm) and its cap (18-21 cm) with a 3 cm unseen neck between them: two
  // Euclidean clusters (tolerance 2 cm), one object. A second box 20 cm away stays separate.
  std::mt19937 rng(9);
  auto cloud = std::make_shared<CloudXYZ>();
  addPatch(*cloud, Eigen::Vector3f(0.2f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.6f,
           0.005f, 0.001f, rng);
  const Eigen::Vector3f eye(0.2f, -0.2f, 0.8f);
  addBox(*cloud, Eigen::Vector2f(0.5f, 0.0f), 0.0f, Eigen::Vector3f(0.06f, 0.06f, 0.15f), 0.005f, rng, eye);
  addBox(*cloud, Eigen::Vector2f(0.5f, 0.0f), 0.18f, Eigen::Vector3f(0.03f, 0.03f, 0.03f), 0.005f, rng, eye);
  addBox(*cloud, Eigen::Vector2f(0.5f, 0.2f), 0.0f, Eigen::Vector3f(0.05f, 0.05f, 0.1f), 0.005f, rng, eye);
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.5f, 0.1f, 0.0f));
  TableSegmentationParams params;
  params.target = TargetCluster::ClosestToPoint;
  params.target_point_m = Eigen::Vector3f(0.5f, 0.0f, 0.1f);
  params.merge_stacked_clusters = false;
  TableSegmentationResult result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 3u);
  EXPECT_LT(result.object_max.z(), 0.16f);

  params.merge_stacked_clusters = true;
  result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.merged_clusters, 1);
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_NEAR(result.object_max.z(), 0.21f, 0.003f);  // the cap is part of the object
  EXPECT_LT(result.object_max.y(), 0.04f);             // the neighbour is not
  EXPECT_EQ(result.object->size(), result.clusters[result.target_index].indices.size());

  // The same from the cap's side: choosing the cap gives the whole bottle too.
  params.target_point_m = Eigen::Vector3f(0.5f, 0.0f, 0.25f);
  result = segmentTable(cloud, params);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.object_min.z(), 0.01f, 0.006f);
  EXPECT_NEAR(result.object_max.z(), 0.21f, 0.003f);
}

namespace
{
/// Upright cylinder side and top as a camera at `eye` sees them.
void addCylinder(CloudXYZ& cloud, const Eigen::Vector2f& centre_xy, float radius, float height, float step,
                 std::mt19937& rng, const Eigen::Vector3f& eye)
{
  std::normal_distribution<float> noise(0.0f, 0.0005f);
  const int around = static_cast<int>(2.0f * static_cast<float>(M_PI) * radius / step);
  for (int a = 0; a < around; ++a)
  {
    const float angle = 2.0f * static_cast<float>(M_PI) * static_cast<float>(a) / static_cast<float>(around);
    const Eigen::Vector3f outward(std::cos(angle), std::sin(angle), 0.0f);
    for (float z = 0.0f; z <= height; z += step)
    {
      const Eigen::Vector3f p = Eigen::Vector3f(centre_xy.x(), centre_xy.y(), z) + radius * outward;
      if ((eye - p).dot(outward) > 0.0f)
        cloud.push_back(PointXYZ(p.x() + noise(rng), p.y() + noise(rng), p.z() + noise(rng)));
    }
  }
  for (float x = -radius; x <= radius; x += step)
    for (float y = -radius; y <= radius; y += step)
      if (x * x + y * y <= radius * radius)
        cloud.push_back(PointXYZ(centre_xy.x() + x, centre_xy.y() + y, height + noise(rng)));
}

/// An open pot standing on z = 0 (outer radius `radius`, thin wall, inner bottom `floor` high), as
/// one camera at `eye` sees it: the outside of the near wall, and through the opening the inside
/// of the far wall and the bottom; no rim (a thin wall returns nothing there). A surface seen at
/// more than `max_incidence_rad` from its normal returns nothing, as the Xtion's grazing cutoff.
void addOpenPot(CloudXYZ& cloud, const Eigen::Vector2f& centre_xy, float radius, float height, float floor,
                float step, float max_incidence_rad, std::mt19937& rng, const Eigen::Vector3f& eye)
{
  std::normal_distribution<float> noise(0.0f, 0.0005f);
  const float inner = radius - 0.003f;
  const float min_cosine = std::cos(max_incidence_rad);
  const Eigen::Vector3f centre(centre_xy.x(), centre_xy.y(), 0.0f);
  auto faces = [&](const Eigen::Vector3f& p, const Eigen::Vector3f& normal) {
    return (eye - p).normalized().dot(normal) > min_cosine;
  };
  // Seen through the opening: the line of sight crosses the rim's plane inside the inner wall.
  auto throughOpening = [&](const Eigen::Vector3f& p) {
    const Eigen::Vector3f ray = eye - p;
    const Eigen::Vector3f at_rim = p + ray * ((height - p.z()) / ray.z());
    return (at_rim - centre).head<2>().norm() < inner;
  };
  auto add = [&](const Eigen::Vector3f& p) { cloud.push_back(PointXYZ(p.x() + noise(rng), p.y() + noise(rng), p.z() + noise(rng))); };
  const int around = static_cast<int>(2.0f * static_cast<float>(M_PI) * radius / step);
  for (int a = 0; a < around; ++a)
  {
    const float angle = 2.0f * static_cast<float>(M_PI) * static_cast<float>(a) / static_cast<float>(around);
    const Eigen::Vector3f outward(std::cos(angle), std::sin(angle), 0.0f);
    for (float z = 0.5f * step; z < height; z += step)
    {
      const Eigen::Vector3f outside = centre + Eigen::Vector3f(0.0f, 0.0f, z) + radius * outward;
      if (faces(outside, outward))
        add(outside);
      const Eigen::Vector3f inside = centre + Eigen::Vector3f(0.0f, 0.0f, z) + inner * outward;
      if (z > floor && faces(inside, -outward) && throughOpening(inside))
        add(inside);
    }
  }
  for (float x = -inner; x <= inner; x += step)
    for (float y = -inner; y <= inner; y += step)
    {
      const Eigen::Vector3f bottom = centre + Eigen::Vector3f(x, y, floor);
      if (x * x + y * y <= inner * inner && faces(bottom, Eigen::Vector3f::UnitZ()) && throughOpening(bottom))
        add(bottom);
    }
}

/// For the object whose points are cloud[first, last): does one cluster hold it alone (the
/// cluster holding most of it is >= 90 % this object and holds >= 80 % of it)? `above_table`:
/// the share of its points higher than min_height_above_table_m (the rest are never object).
bool comesOutAlone(const TableSegmentationResult& result, std::size_t first, std::size_t last, double above_table = 0.85)
{
  std::size_t best_overlap = 0, best_size = 0;
  for (const auto& cluster : result.clusters)
  {
    std::size_t overlap = 0;
    for (const auto i : cluster.indices)
      overlap += static_cast<std::size_t>(i) >= first && static_cast<std::size_t>(i) < last ? 1 : 0;
    if (overlap > best_overlap)
    {
      best_overlap = overlap;
      best_size = cluster.indices.size();
    }
  }
  // Points within min_height_above_table_m of the table are never object: count against the
  // object's points above that height.
  return best_size > 0 && best_overlap >= 0.9 * static_cast<double>(best_size) &&
         best_overlap >= 0.8 * above_table * static_cast<double>(last - first);
}
}  // namespace

TEST(TableSegmentation, TouchingObjectsAreCutAtTheirConcaveCrease)
{
  const Eigen::Vector3f eye(0.2f, -0.25f, 0.7f);
  // The table as the camera sees it: a table point is hidden when an object point lies on its
  // line of sight (the split's standing test relies on where the table was seen).
  auto scene = [&](auto&& add_objects, std::vector<std::size_t>& bounds) {
    std::mt19937 rng(11);
    CloudXYZ objects, table;
    std::vector<std::size_t> ends;
    add_objects(objects, rng, ends);
    addPatch(table, Eigen::Vector3f(0.3f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.5f, 0.6f,
             0.005f, 0.001f, rng);
    auto cloud = std::make_shared<CloudXYZ>(visibleFrom(eye, table, objects));
    bounds.assign(1, cloud->size());
    for (const std::size_t end : ends)
      bounds.push_back(cloud->size() + end);
    *cloud += objects;
    finish(*cloud);
    aimCamera(*cloud, eye, Eigen::Vector3f(0.55f, 0.0f, 0.05f));
    return cloud;
  };
  TableSegmentationParams params;
  params.split_concave_creases = true;
  TableSegmentationParams euclidean_only = params;
  euclidean_only.split_concave_creases = false;

  // A small box lying against a tall box's front face (both within the clustering tolerance).
  std::vector<std::size_t> bounds;
  auto boxes = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.06f, 0.1f, 0.2f), 0.005f, rng, eye);
        b.push_back(cloud.size());
        addBox(cloud, Eigen::Vector2f(0.54f, 0.0f), 0.0f, Eigen::Vector3f(0.06f, 0.08f, 0.05f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  TableSegmentationResult result = segmentTable(boxes, euclidean_only);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 1u) << "Euclidean clustering alone merges touching objects";
  result = segmentTable(boxes, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_TRUE(comesOutAlone(result, bounds[0], bounds[1])) << "tall box";
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2])) << "small box";

  // A box standing on a flat box: stacked, yet two objects (a crease, not a gap, parts them,
  // so merge_stacked_clusters keeps them apart).
  auto stack = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.14f, 0.14f, 0.04f), 0.005f, rng, eye);
        b.push_back(cloud.size());
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.04f, Eigen::Vector3f(0.05f, 0.06f, 0.1f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  ASSERT_TRUE(params.merge_stacked_clusters);
  result = segmentTable(stack, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2])) << "standing box";

  // Two cans side by side, touching along a line: the groove between them is concave.
  auto cans = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addCylinder(cloud, Eigen::Vector2f(0.6f, -0.035f), 0.035f, 0.12f, 0.005f, rng, eye);
        b.push_back(cloud.size());
        addCylinder(cloud, Eigen::Vector2f(0.6f, 0.035f), 0.035f, 0.12f, 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  result = segmentTable(cans, euclidean_only);
  EXPECT_EQ(result.clusters.size(), 1u);
  result = segmentTable(cans, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_TRUE(comesOutAlone(result, bounds[0], bounds[1])) << "left can";
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2])) << "right can";

  // A handle sticking out of a box's side meets it at a concave crease, but nothing holds it up
  // but the box (the camera sees the table under it): one object.
  auto handled = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.06f, 0.08f, 0.12f), 0.005f, rng, eye);
        addBox(cloud, Eigen::Vector2f(0.6f, -0.075f), 0.07f, Eigen::Vector3f(0.025f, 0.07f, 0.025f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  result = segmentTable(handled, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 1u);

  // In a pile a flat box may lie on objects the camera cannot see, its bottom 5 cm above the
  // table, with a small box standing on it: the flat box cannot stand, but the small box rests
  // on it and cannot hold it up either (its bottom is higher): two objects.
  auto lifted = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.05f, Eigen::Vector3f(0.16f, 0.2f, 0.06f), 0.005f, rng, eye);
        b.push_back(cloud.size());
        addBox(cloud, Eigen::Vector2f(0.6f, 0.02f), 0.11f, Eigen::Vector3f(0.05f, 0.06f, 0.04f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  result = segmentTable(lifted, euclidean_only);
  EXPECT_EQ(result.clusters.size(), 1u);
  result = segmentTable(lifted, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2])) << "small box on the lifted one";

  // A small thing lying against a tall box (a battery against a cup) leaves fewer points than
  // min_piece_points once its crease with the box is taken off, but it stands on the table: an
  // object, where a sliver of one box would hang above it.
  auto small = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addBox(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.0f, Eigen::Vector3f(0.06f, 0.1f, 0.2f), 0.005f, rng, eye);
        b.push_back(cloud.size());
        addBox(cloud, Eigen::Vector2f(0.562f, 0.0f), 0.0f, Eigen::Vector3f(0.016f, 0.05f, 0.016f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  TableSegmentationParams large_pieces_only = params;
  large_pieces_only.concave_split.min_standing_piece_points = 0;
  result = segmentTable(small, large_pieces_only);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 1u) << "without the standing rule the small piece joins the box";
  result = segmentTable(small, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  std::size_t small_above = 0;
  for (std::size_t i = bounds[1]; i < bounds[2]; ++i)
    small_above += small->points[i].z > params.min_height_above_table_m ? 1 : 0;
  // The crease band between the two goes to the tall box: a 16 mm box keeps ~3/4 of its points.
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2],
                            0.9 * static_cast<double>(small_above) / static_cast<double>(bounds[2] - bounds[1])))
      << "small box lying against the tall one";

  // One convex object is never cut: a single can, a single box.
  auto can = scene(
      [&](CloudXYZ& cloud, std::mt19937& rng, std::vector<std::size_t>& b) {
        addCylinder(cloud, Eigen::Vector2f(0.6f, 0.0f), 0.04f, 0.15f, 0.005f, rng, eye);
        b.push_back(cloud.size());
        addBox(cloud, Eigen::Vector2f(0.6f, 0.2f), 0.0f, Eigen::Vector3f(0.06f, 0.08f, 0.12f), 0.005f, rng, eye);
        b.push_back(cloud.size());
      },
      bounds);
  result = segmentTable(can, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
}

TEST(TableSegmentation, AnOpenPotsInsideSeenApartFromItsOuterWallIsJoinedToIt)
{
  // A pot 18 cm wide seen from 45 degrees above: its side walls, edge-on to the camera, return
  // nothing, so the inside of its far wall and bottom lie more than the clustering tolerance
  // from the outside of its near wall (as the mOSD scenes learn36 and learn38 show).
  const Eigen::Vector3f eye(0.2f, 0.0f, 0.45f);
  std::mt19937 rng(5);
  CloudXYZ objects, table;
  addOpenPot(objects, Eigen::Vector2f(0.6f, 0.0f), 0.09f, 0.1f, 0.005f, 0.005f, 1.22f, rng, eye);
  const std::size_t pot_end = objects.size();
  // A small box in front of the pot, left of the line of sight: an object of its own.
  addBox(objects, Eigen::Vector2f(0.42f, -0.09f), 0.0f, Eigen::Vector3f(0.05f, 0.05f, 0.06f), 0.005f, rng, eye);
  addPatch(table, Eigen::Vector3f(0.3f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.5f, 0.6f,
           0.005f, 0.001f, rng);
  auto cloud = std::make_shared<CloudXYZ>(visibleFrom(eye, table, objects));
  const std::size_t first = cloud->size();
  *cloud += objects;
  finish(*cloud);
  aimCamera(*cloud, eye, Eigen::Vector3f(0.6f, 0.0f, 0.05f));

  for (const bool split : {false, true})
  {
    TableSegmentationParams params;
    params.split_concave_creases = split;
    ASSERT_TRUE(params.join_container_insides) << "on by default";
    TableSegmentationParams apart = params;
    apart.join_container_insides = false;
    TableSegmentationResult result = segmentTable(cloud, apart);
    ASSERT_TRUE(result.ok()) << result.reason;
    EXPECT_EQ(result.clusters.size(), 3u) << "the gap parts the pot (split " << split << ")";
    result = segmentTable(cloud, params);
    ASSERT_TRUE(result.ok()) << result.reason;
    EXPECT_EQ(result.clusters.size(), 2u) << "split " << split;
    EXPECT_TRUE(comesOutAlone(result, first, first + pot_end)) << "pot, split " << split;
    EXPECT_TRUE(comesOutAlone(result, first + pot_end, cloud->size())) << "box, split " << split;
  }
}

TEST(TableSegmentation, AnObjectAnotherHidesInTheMiddleIsOneClusterAndASeenGapKeepsTwo)
{
  // The camera looks along +x over a narrow tall box standing in front of what lies behind it.
  const Eigen::Vector3f eye(0.0f, 0.0f, 0.5f);
  // bounds: [0] end of the table, then the end of each back object; the occluder comes last.
  auto scene = [&](const std::vector<std::pair<float, Eigen::Vector3f>>& back_boxes, float occluder_width_m,
                   std::vector<std::size_t>& bounds) {
    std::mt19937 rng(5);
    CloudXYZ occluder, table;
    addBox(occluder, Eigen::Vector2f(0.45f, 0.0f), 0.0f, Eigen::Vector3f(0.04f, occluder_width_m, 0.25f), 0.005f, rng, eye);
    std::vector<CloudXYZ> backs;
    CloudXYZ all_objects = occluder;
    for (const auto& [y, size] : back_boxes)
    {
      CloudXYZ box;
      addBox(box, Eigen::Vector2f(0.7f, y), 0.0f, size, 0.005f, rng, eye);
      backs.push_back(visibleFrom(eye, box, occluder));
      all_objects += box;
    }
    addPatch(table, Eigen::Vector3f(0.3f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.6f,
             0.005f, 0.001f, rng);
    auto cloud = std::make_shared<CloudXYZ>(visibleFrom(eye, table, all_objects));
    bounds.assign(1, cloud->size());
    for (const CloudXYZ& back : backs)
    {
      *cloud += back;
      bounds.push_back(cloud->size());
    }
    *cloud += occluder;
    finish(*cloud);
    aimCamera(*cloud, eye, Eigen::Vector3f(0.6f, 0.0f, 0.05f));
    return cloud;
  };
  TableSegmentationParams params;
  params.join_occluded_pieces = true;
  TableSegmentationParams separate = params;
  separate.join_occluded_pieces = false;

  // A 16 cm wide box behind a 4 cm wide one: its middle 6 cm are hidden, left and right show.
  std::vector<std::size_t> bounds;
  const auto hidden_middle = scene({ { 0.0f, Eigen::Vector3f(0.06f, 0.16f, 0.08f) } }, 0.04f, bounds);
  TableSegmentationResult result = segmentTable(hidden_middle, separate);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 3u) << "Euclidean clusters: the occluder and the back box's two visible pieces";
  result = segmentTable(hidden_middle, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 2u);
  EXPECT_TRUE(comesOutAlone(result, bounds[0], bounds[1])) << "the hidden box is one cluster";

  // Two 5 cm boxes 6 cm apart behind a 2 cm wide box: the camera sees the table between them.
  const auto seen_gap = scene({ { -0.055f, Eigen::Vector3f(0.06f, 0.05f, 0.08f) },
                                { 0.055f, Eigen::Vector3f(0.06f, 0.05f, 0.08f) } },
                              0.02f, bounds);
  result = segmentTable(seen_gap, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 3u);
  EXPECT_TRUE(comesOutAlone(result, bounds[0], bounds[1])) << "left box";
  EXPECT_TRUE(comesOutAlone(result, bounds[1], bounds[2])) << "right box";

  // Two boxes whose gap the occluder hides, but whose tops differ by 4 cm: two objects.
  const auto other_heights = scene({ { -0.055f, Eigen::Vector3f(0.06f, 0.05f, 0.08f) },
                                     { 0.055f, Eigen::Vector3f(0.06f, 0.05f, 0.04f) } },
                                   0.04f, bounds);
  result = segmentTable(other_heights, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 3u);
}

namespace
{
/// A round part lying along x on the table (its axis `axis_height` up), from `x0` to `x1` at
/// `y`: the side the camera at `eye` sees and, when `base`, the disc closing its x0 end.
void addLyingRound(CloudXYZ& cloud, float x0, float x1, float y, float radius, float axis_height, float step,
                   bool base, const Eigen::Vector3f& eye)
{
  const int around = static_cast<int>(2.0f * static_cast<float>(M_PI) * radius / step);
  for (int a = 0; a < around; ++a)
  {
    const float angle = 2.0f * static_cast<float>(M_PI) * static_cast<float>(a) / static_cast<float>(around);
    const Eigen::Vector3f outward(0.0f, std::cos(angle), std::sin(angle));
    for (float x = x0; x <= x1; x += step)
    {
      const Eigen::Vector3f p = Eigen::Vector3f(x, y, axis_height) + radius * outward;
      if ((eye - p).dot(outward) > 0.0f)
        cloud.push_back(PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  if (base && eye.x() < x0)
    for (float v = -radius; v <= radius; v += step)
      for (float w = -radius; w <= radius; w += step)
        if (v * v + w * w <= radius * radius)
          cloud.push_back(PointXYZ(x0, y + v, axis_height + w));
}
}  // namespace

TEST(TableSegmentation, ALyingBottlesNeckCutOffAtItsHiddenShoulderIsJoinedToItsBody)
{
  // A wine bottle lying along x, seen from behind its base: body 20 cm long, radius 3.8 cm; its
  // 1.5 cm neck starts 5 cm past the body (the shoulder sloping away, hidden by the body's top),
  // so Euclidean clustering (2 cm) gives two clusters. The neck hangs clear of the table on the
  // body's axis, between its mid-height and its top: one object.
  const Eigen::Vector3f eye(0.1f, -0.1f, 0.5f);
  auto scene = [&](auto&& add_objects) {
    std::mt19937 rng(5);
    CloudXYZ objects, table;
    add_objects(objects, rng);
    addPatch(table, Eigen::Vector3f(0.25f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.6f, 0.6f,
             0.005f, 0.001f, rng);
    auto cloud = std::make_shared<CloudXYZ>(visibleFrom(eye, table, objects));
    *cloud += objects;
    finish(*cloud);
    aimCamera(*cloud, eye, Eigen::Vector3f(0.5f, 0.0f, 0.04f));
    return cloud;
  };
  auto bottle = [&](float neck_y) {
    return [&eye, neck_y](CloudXYZ& cloud, std::mt19937&) {
      addLyingRound(cloud, 0.35f, 0.55f, 0.0f, 0.038f, 0.038f, 0.005f, true, eye);
      addLyingRound(cloud, 0.60f, 0.68f, neck_y, 0.015f, 0.038f, 0.005f, false, eye);
    };
  };
  TableSegmentationParams params;
  params.target = TargetCluster::Largest;
  EXPECT_TRUE(params.join_lying_necks) << "on by default (session 32)";
  TableSegmentationParams apart = params;
  apart.join_lying_necks = false;

  const auto lying = scene(bottle(0.0f));
  TableSegmentationResult result = segmentTable(lying, apart);
  ASSERT_TRUE(result.ok()) << result.reason;
  ASSERT_EQ(result.clusters.size(), 2u) << "the hidden shoulder parts body and neck";
  result = segmentTable(lying, params);
  ASSERT_TRUE(result.ok()) << result.reason;
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_NEAR(result.object_max.x(), 0.68f, 0.006f) << "the neck's tip is the object's";
  EXPECT_NEAR(result.object_min.x(), 0.35f, 0.006f);
  // The same with the concave split on (the clutter pipeline's setting).
  TableSegmentationParams split = params;
  split.split_concave_creases = true;
  result = segmentTable(lying, split);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_EQ(result.clusters.size(), 1u);

  auto clustersOf = [&](const CloudXYZ::Ptr& cloud) {
    const TableSegmentationResult segmented = segmentTable(cloud, params);
    EXPECT_TRUE(segmented.ok()) << segmented.reason;
    return segmented.clusters.size();
  };
  // A neck 8 cm off the body's axis (beyond its 3.8 cm half-width) is something else.
  EXPECT_EQ(clustersOf(scene(bottle(0.08f))), 2u);
  // A box past the body's end, on its axis: standing on the table (an object of its own), or
  // resting higher than the body's top (on something hidden): neither is a neck.
  for (const float box_floor : { 0.0f, 0.06f })
    EXPECT_EQ(clustersOf(scene([&eye, box_floor](CloudXYZ& cloud, std::mt19937& rng) {
                addLyingRound(cloud, 0.35f, 0.55f, 0.0f, 0.038f, 0.038f, 0.005f, true, eye);
                addBox(cloud, Eigen::Vector2f(0.62f, 0.0f), box_floor, Eigen::Vector3f(0.03f, 0.03f, 0.03f), 0.005f, rng, eye);
              })),
              2u)
        << "box standing at " << box_floor << " m";

  TableSegmentationParams bad = params;
  bad.neck_join.max_gap_m = -0.01;
  EXPECT_FALSE(segmentTable(lying, bad).ok());
}

TEST(TableSegmentation, BadInputAndMissingPartsGiveTypedFailures)
{
  std::mt19937 rng(5);
  TableSegmentationResult result;
  ASSERT_NO_THROW(result = segmentTable(nullptr, TableSegmentationParams()));
  EXPECT_EQ(result.failure, SegmentationFailure::InvalidInput);
  ASSERT_TRUE(result.object && result.scene && result.table);
  EXPECT_EQ(segmentTable(std::make_shared<CloudXYZ>(), TableSegmentationParams()).failure,
            SegmentationFailure::InvalidInput);

  auto nan_cloud = std::make_shared<CloudXYZ>();
  nan_cloud->push_back(PointXYZ(kNaN, 0.0f, 0.0f));
  EXPECT_EQ(segmentTable(nan_cloud, TableSegmentationParams()).failure, SegmentationFailure::InvalidInput);

  // A vertical wall only: no near-horizontal plane.
  auto wall = std::make_shared<CloudXYZ>();
  addPatch(*wall, Eigen::Vector3f(0.5f, -0.3f, 0.0f), Eigen::Vector3f::UnitY(), Eigen::Vector3f::UnitZ(), 0.6f, 0.4f,
           0.005f, 0.001f, rng);
  finish(*wall);
  result = segmentTable(wall, TableSegmentationParams());
  EXPECT_EQ(result.failure, SegmentationFailure::NoPlane) << result.reason;
  EXPECT_NE(result.reason.find("no plane"), std::string::npos);

  // A bare table: plane, no cluster; the scene is the whole table.
  auto table = std::make_shared<CloudXYZ>();
  addPatch(*table, Eigen::Vector3f(0.2f, -0.3f, 0.0f), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0.5f, 0.6f,
           0.005f, 0.001f, rng);
  finish(*table);
  result = segmentTable(table, TableSegmentationParams());
  EXPECT_EQ(result.failure, SegmentationFailure::NoCluster) << result.reason;
  EXPECT_TRUE(result.has_plane);
  EXPECT_EQ(result.scene->size(), table->size());
  EXPECT_TRUE(result.object->empty());

  // An object beyond max_object_distance_m.
  addBox(*table, Eigen::Vector2f(0.65f, 0.0f), 0.0f, Eigen::Vector3f(0.05f, 0.05f, 0.1f), 0.005f, rng,
         Eigen::Vector3f(0.3f, 0.0f, 0.8f));
  finish(*table);
  TableSegmentationParams params;
  params.max_object_distance_m = 0.5;
  result = segmentTable(table, params);
  EXPECT_EQ(result.failure, SegmentationFailure::ObjectOutOfReach) << result.reason;
  EXPECT_FALSE(result.object->empty());

  params = TableSegmentationParams();
  params.cluster_tolerance_m = 0.0;
  EXPECT_EQ(segmentTable(table, params).failure, SegmentationFailure::InvalidInput);
}

// ------------------------------------------------------------------------------------------
// Normals

TEST(NormalEstimation, SphereNormalsPointOutwardTowardTheSensor)
{
  // Sphere r = 5 cm at 0.6 m from the camera, rays 2 mrad apart (~1.2 mm at that range),
  // 0.5 mm axial noise: the outward normal (p - centre) / r is the truth.
  const Eigen::Vector3f eye(0.0f, 0.0f, 0.6f);
  const Eigen::Vector3f centre(0.45f, 0.1f, 0.2f);
  const float radius = 0.05f;
  const CloudXYZ::Ptr sphere = raycastSphere(eye, centre, radius, 120, 0.002f, 0.0005f, 11);
  ASSERT_GT(sphere->size(), 1000u);
  finish(*sphere);
  NormalParams params;
  params.k_neighbours = 20;
  const NormalResult result = estimateNormals(sphere, eye, params);
  ASSERT_TRUE(result.ok) << result.reason;
  ASSERT_GT(result.cloud->size(), sphere->size() * 99 / 100);
  EXPECT_TRUE(result.cloud->sensor_origin_.head<3>().isApprox(eye));
  std::size_t within_10deg = 0;
  for (const auto& p : result.cloud->points)
  {
    const Eigen::Vector3f n = p.getNormalVector3fMap();
    EXPECT_NEAR(n.norm(), 1.0f, 1e-3f);
    EXPECT_GE(n.dot(eye - p.getVector3fMap()), 0.0f) << "normal must face the sensor";
    if (angleBetween(n, p.getVector3fMap() - centre) < 10.0 * M_PI / 180.0)
      ++within_10deg;
  }
  // Grazing-angle points at the silhouette have one-sided neighbourhoods; allow 2 % there.
  EXPECT_GE(within_10deg, result.cloud->size() * 98 / 100);
}

TEST(NormalEstimation, DownsampledNormalsAreOriginalPointsWithTheirNormals)
{
  // Plane z = 0, 1 mm grid over 10 x 10 cm, normals alternating in length-one tilt so that a
  // copied normal is recognisable: each output point must be an input point with its normal.
  CloudNormal dense;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j)
    {
      PointNormal p;
      p.x = 0.0005f + 0.001f * i;
      p.y = 0.0005f + 0.001f * j;
      p.z = 0.0f;
      const Eigen::Vector3f n = Eigen::Vector3f(0.001f * i, 0.0f, 1.0f).normalized();
      p.normal_x = n.x();
      p.normal_y = n.y();
      p.normal_z = n.z();
      dense.push_back(p);
    }
  dense.sensor_origin_ = Eigen::Vector4f(0, 0, 1, 0);
  const CloudNormal::Ptr sparse = downsampleNormals(dense, 0.01);
  ASSERT_EQ(sparse->size(), 100u);  // one per 1 cm voxel
  EXPECT_TRUE(sparse->sensor_origin_.isApprox(dense.sensor_origin_));
  for (const auto& p : sparse->points)
  {
    const int i = static_cast<int>(std::lround((p.x - 0.0005f) / 0.001f));
    const int j = static_cast<int>(std::lround((p.y - 0.0005f) / 0.001f));
    ASSERT_TRUE(i >= 0 && i < 100 && j >= 0 && j < 100);
    EXPECT_NEAR(p.x, 0.0005f + 0.001f * i, 1e-6f);  // an original grid point
    EXPECT_NEAR(p.normal_x, dense.points[i * 100 + j].normal_x, 1e-6f);
    // The nearest original point to a voxel centroid is one of the four central ones.
    EXPECT_NEAR(std::fmod(p.x, 0.01f), 0.005f, 0.0011f);
  }
  EXPECT_TRUE(downsampleNormals(CloudNormal(), 0.01)->empty());
  EXPECT_EQ(downsampleNormals(dense, 0.0)->size(), dense.size());
}

TEST(NormalEstimation, BadInputGivesReasonNotThrow)
{
  const Eigen::Vector3f eye(0, 0, 1);
  NormalResult result;
  ASSERT_NO_THROW(result = estimateNormals(nullptr, eye, NormalParams()));
  EXPECT_FALSE(result.ok);
  ASSERT_TRUE(result.cloud);
  EXPECT_FALSE(estimateNormals(std::make_shared<CloudXYZ>(), eye, NormalParams()).ok);

  auto few = std::make_shared<CloudXYZ>();
  for (int i = 0; i < 5; ++i)
    few->push_back(PointXYZ(0.01f * i, 0.0f, 0.0f));
  result = estimateNormals(few, eye, NormalParams());
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("degenerate"), std::string::npos) << result.reason;

  // 50 coincident points: no plane can be fitted to any neighbourhood.
  auto coincident = std::make_shared<CloudXYZ>();
  for (int i = 0; i < 50; ++i)
    coincident->push_back(PointXYZ(0.3f, 0.1f, 0.0f));
  ASSERT_NO_THROW(result = estimateNormals(coincident, eye, NormalParams()));
  EXPECT_FALSE(result.ok) << result.reason;

  auto with_nan = std::make_shared<CloudXYZ>(*few);
  for (int i = 0; i < 20; ++i)
    with_nan->push_back(PointXYZ(0.01f * i, 0.02f * (i % 3), 0.0f));
  with_nan->push_back(PointXYZ(kNaN, 0.0f, 0.0f));
  EXPECT_FALSE(estimateNormals(with_nan, eye, NormalParams()).ok);
  EXPECT_FALSE(estimateNormals(few, Eigen::Vector3f(kNaN, 0, 0), NormalParams()).ok);
}
