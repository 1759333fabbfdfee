// Xtion renderer: depth, projection, noise statistics and failure modes against analytic scenes.
#include "fast_grasp/render/xtion_renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <numeric>
#include <string>

namespace fast_grasp
{
namespace
{
constexpr double kPi = 3.14159265358979323846;

// A camera at the origin looking along world +z: optical frame == world frame.
const Eigen::Isometry3d kIdentityCamera = Eigen::Isometry3d::Identity();
// Depth comes from integer disparity levels (2.8 mm apart at 1 m) rounded to whole millimetres;
// rounding a handful of discrete levels does not average out, so a mean may be off by < 0.5 mm.
constexpr double kLevelBiasM = 0.5e-3;

// Square plate facing the camera (normal along -z) at depth_m, size_m wide, optionally tilted
// about the world y axis by tilt_rad (incidence angle for the central pixel).
ScenePart plate(double depth_m, double size_m, double tilt_rad = 0.0, int label = 1)
{
  ScenePart part;
  part.mesh = makeBox(size_m, size_m, 0.001);
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translate(Eigen::Vector3f(0.0f, 0.0f, static_cast<float>(depth_m)));
  pose.rotate(Eigen::AngleAxisf(static_cast<float>(tilt_rad), Eigen::Vector3f::UnitY()));  // front face at depth_m
  part.mesh.transform(pose);
  part.label = label;
  return part;
}

struct DepthStats
{
  size_t count = 0;
  double mean = 0.0;
  double sigma = 0.0;
};

// Depth statistics over a central window of the image.
DepthStats centralDepthStats(const RenderedFrame& frame, int half_window_px)
{
  std::vector<double> depths;
  for (int v = 240 - half_window_px; v < 240 + half_window_px; ++v)
    for (int u = 320 - half_window_px; u < 320 + half_window_px; ++u)
      if (std::isfinite(frame.at(u, v).z()))
        depths.push_back(frame.at(u, v).z());
  DepthStats stats;
  stats.count = depths.size();
  if (depths.empty())
    return stats;
  stats.mean = std::accumulate(depths.begin(), depths.end(), 0.0) / depths.size();
  double sq = 0.0;
  for (double d : depths)
    sq += (d - stats.mean) * (d - stats.mean);
  stats.sigma = std::sqrt(sq / depths.size());
  return stats;
}
}  // namespace

TEST(XtionRenderer, PlaneRendersAtItsDepthWithinThreeSigma)
{
  XtionRenderer renderer({ plate(1.0, 3.0) });
  const RenderedFrame frame = renderer.render(kIdentityCamera, 1);
  ASSERT_EQ(frame.width, 640);
  ASSERT_EQ(frame.height, 480);
  const double sigma = axialNoiseSigma(1.0, 0.0);
  size_t valid = 0, within = 0;
  for (const auto& p : frame.points)
  {
    if (!std::isfinite(p.z()))
      continue;
    ++valid;
    // Off-axis pixels see the plate slightly obliquely; their sigma is at most a few % larger.
    if (std::abs(p.z() - 1.0) < 3.0 * sigma * 1.05)
      ++within;
  }
  EXPECT_GT(valid, 0.97 * 640 * 480);  // only dropout and lateral jitter lose pixels
  EXPECT_GT(static_cast<double>(within) / valid, 0.99);
  const DepthStats stats = centralDepthStats(frame, 100);
  EXPECT_NEAR(stats.mean, 1.0, 3.0 * sigma / std::sqrt(static_cast<double>(stats.count)) + kLevelBiasM);
}

TEST(XtionRenderer, NoiseFreeProjectionMatchesPinholeModel)
{
  // A 10 cm cube face centred at (0.1, -0.05, 1.2): its pixels must span the projected square.
  ScenePart cube;
  cube.mesh = makeBox(0.1, 0.1, 0.1);
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translate(Eigen::Vector3f(0.1f, -0.05f, 1.2f));  // its base (z = 0) faces the camera
  cube.mesh.transform(pose);
  cube.label = 7;
  XtionRenderer renderer({ cube });
  const RenderedFrame frame = renderer.renderNoiseFree(kIdentityCamera);
  const XtionIntrinsics k;
  int u_min = 10000, u_max = -1, v_min = 10000, v_max = -1;
  for (int v = 0; v < frame.height; ++v)
    for (int u = 0; u < frame.width; ++u)
      if (frame.labelAt(u, v) == 7 && std::isfinite(frame.at(u, v).z()))  // side faces: grazing, NaN
      {
        u_min = std::min(u_min, u);
        u_max = std::max(u_max, u);
        v_min = std::min(v_min, v);
        v_max = std::max(v_max, v);
        const Eigen::Vector3f& p = frame.at(u, v);
        EXPECT_NEAR(p.z(), 1.2, 1e-4);
        EXPECT_NEAR(k.fx * p.x() / p.z() + k.cx, u, 1e-3);
        EXPECT_NEAR(k.fy * p.y() / p.z() + k.cy, v, 1e-3);
      }
  // Projected edges of the face at z = 1.2: x in [0.05, 0.15], y in [-0.1, 0.0].
  EXPECT_NEAR(u_min, k.fx * 0.05 / 1.2 + k.cx, 1.0);
  EXPECT_NEAR(u_max, k.fx * 0.15 / 1.2 + k.cx, 1.0);
  EXPECT_NEAR(v_min, k.fy * -0.10 / 1.2 + k.cy, 1.0);
  EXPECT_NEAR(v_max, k.fy * 0.00 / 1.2 + k.cy, 1.0);
}

TEST(XtionRenderer, MeasuredNoiseMatchesNguyenModelAtOneAndTwoMetres)
{
  for (double depth : { 1.0, 2.0 })
  {
    XtionRenderer renderer({ plate(depth, 6.0) });
    const RenderedFrame frame = renderer.render(kIdentityCamera, 42);
    const DepthStats stats = centralDepthStats(frame, 60);  // near-normal incidence
    ASSERT_GT(stats.count, 10000u);
    const double expected = axialNoiseSigma(depth, 0.0);
    EXPECT_NEAR(stats.sigma, expected, 0.2 * expected) << "depth " << depth;
    EXPECT_NEAR(stats.mean, depth, 3.0 * expected / std::sqrt(static_cast<double>(stats.count)) + kLevelBiasM);
  }
}

TEST(XtionRenderer, DepthIsQuantisedToWholeMillimetres)
{
  XtionRenderer renderer({ plate(1.5, 4.0) });
  const RenderedFrame frame = renderer.render(kIdentityCamera, 3);
  for (int u = 300; u < 340; ++u)
  {
    const float z = frame.at(u, 240).z();
    if (std::isfinite(z))
      EXPECT_NEAR(z * 1000.0, std::round(z * 1000.0), 1e-3);
  }
}

TEST(XtionRenderer, GrazingAnglePixelsAreNaN)
{
  // Incidence at the image centre is the tilt: 80 deg is beyond the ~70 deg limit, 50 deg is not.
  XtionRenderer grazing({ plate(1.5, 3.0, 80.0 * kPi / 180.0) });
  const RenderedFrame grazing_frame = grazing.renderNoiseFree(kIdentityCamera);
  EXPECT_EQ(grazing_frame.labelAt(320, 240), 1);  // the ray does hit the plate ...
  EXPECT_FALSE(std::isfinite(grazing_frame.at(320, 240).z()));  // ... but gives no depth
  size_t hit = 0, valid = 0;
  for (int u = 280; u < 360; ++u)
  {
    hit += grazing_frame.labelAt(u, 240) == 1;
    valid += std::isfinite(grazing_frame.at(u, 240).z());
  }
  EXPECT_GT(hit, 70u);
  EXPECT_EQ(valid, 0u);

  XtionRenderer oblique({ plate(1.5, 3.0, 50.0 * kPi / 180.0) });
  const RenderedFrame oblique_frame = oblique.renderNoiseFree(kIdentityCamera);
  // Pixel 320 is half a pixel right of the axis: ray (a, 0, 1) meets the plate at 1.5 / (1 + a tan 50).
  const double a = 0.5 / 570.3422;
  EXPECT_NEAR(oblique_frame.at(320, 240).z(), 1.5 / (1.0 + a * std::tan(50.0 * kPi / 180.0)), 1e-5);
}

TEST(XtionRenderer, OutOfRangeIsNaN)
{
  XtionRenderer near({ plate(0.4, 2.0) });
  EXPECT_EQ(near.renderNoiseFree(kIdentityCamera).validCount(), 0u);
  XtionRenderer far({ plate(3.8, 12.0) });
  EXPECT_EQ(far.renderNoiseFree(kIdentityCamera).validCount(), 0u);
}

TEST(XtionRenderer, SameSeedGivesIdenticalCloudAndOtherSeedDiffers)
{
  XtionRenderer renderer({ plate(1.2, 3.0) });
  const RenderedFrame a = renderer.render(kIdentityCamera, 11);
  const RenderedFrame b = renderer.render(kIdentityCamera, 11);
  const RenderedFrame c = renderer.render(kIdentityCamera, 12);
  size_t differ_ab = 0, differ_ac = 0;
  for (size_t i = 0; i < a.points.size(); ++i)
  {
    const bool na = std::isfinite(a.points[i].z()), nb = std::isfinite(b.points[i].z()),
               nc = std::isfinite(c.points[i].z());
    differ_ab += (na != nb) || (na && a.points[i] != b.points[i]);
    differ_ac += (na != nc) || (na && a.points[i] != c.points[i]);
  }
  EXPECT_EQ(differ_ab, 0u);
  EXPECT_GT(differ_ac, 1000u);
}

TEST(XtionRenderer, TransparentSurfaceIsNaNAndCastsNoShadow)
{
  ScenePart glass = plate(0.8, 0.2, 0.0, 2);
  glass.transparent = true;
  XtionRenderer renderer({ plate(1.5, 4.0, 0.0, 1), glass });
  const RenderedFrame frame = renderer.renderNoiseFree(kIdentityCamera);
  // Centre pixel sees the glass first: NaN, although the wall behind it is in range.
  EXPECT_EQ(frame.labelAt(320, 240), 2);
  EXPECT_FALSE(std::isfinite(frame.at(320, 240).z()));
  // Outside the glass, left of it (where an opaque plate would shadow), the wall is measured.
  const int u_left_of_glass = static_cast<int>(319.5 - 570.3422 * 0.1 / 0.8) - 3;
  EXPECT_EQ(frame.labelAt(u_left_of_glass, 240), 1);
  EXPECT_NEAR(frame.at(u_left_of_glass, 240).z(), 1.5, 1e-3);
}

TEST(XtionRenderer, ProjectorShadowBesideForegroundEdgeIsNaN)
{
  // Plate of half-width 0.1 m at 0.8 m in front of a wall at 1.5 m. The projector sits 7.5 cm
  // along +x, so the wall is unlit in a band left of the plate: from the camera's silhouette
  // x = -0.1 * 1.5 / 0.8 to the projector's x = 0.075 + (-0.1 - 0.075) * 1.5 / 0.8.
  XtionRenderer renderer({ plate(1.5, 4.0, 0.0, 1), plate(0.8, 0.2, 0.0, 2) });
  const RenderedFrame frame = renderer.renderNoiseFree(kIdentityCamera);
  const XtionIntrinsics k;
  const double camera_edge_x = -0.1 * 1.5 / 0.8;
  const double projector_edge_x = 0.075 + (-0.1 - 0.075) * 1.5 / 0.8;
  const int u_camera_edge = static_cast<int>(std::floor(k.fx * camera_edge_x / 1.5 + k.cx));
  const int u_projector_edge = static_cast<int>(std::ceil(k.fx * projector_edge_x / 1.5 + k.cx));
  ASSERT_GT(u_camera_edge - u_projector_edge, 10);  // a band ~24 px wide
  for (int u = u_projector_edge + 1; u < u_camera_edge; ++u)
  {
    EXPECT_EQ(frame.labelAt(u, 240), 1) << u;
    EXPECT_FALSE(std::isfinite(frame.at(u, 240).z())) << "shadowed wall pixel " << u;
  }
  EXPECT_NEAR(frame.at(u_projector_edge - 2, 240).z(), 1.5, 1e-3);  // lit wall beyond the band
  // The right side of the plate is lit: the wall right next to it is measured.
  const int u_right = static_cast<int>(std::ceil(k.fx * 0.1 / 0.8 + k.cx)) + 2;
  EXPECT_EQ(frame.labelAt(u_right, 240), 1);
  EXPECT_NEAR(frame.at(u_right, 240).z(), 1.5, 1e-3);
  // The plate itself is measured.
  EXPECT_NEAR(frame.at(320, 240).z(), 0.8, 1e-3);
}

TEST(XtionRenderer, ParametricShapesHaveTheirDimensions)
{
  const TriangleMesh cylinder = makeCylinder(0.03, 0.2);
  EXPECT_NEAR(cylinder.minCorner().z(), 0.0, 1e-6);
  EXPECT_NEAR(cylinder.maxCorner().z(), 0.2, 1e-6);
  EXPECT_NEAR(cylinder.maxCorner().x(), 0.03, 1e-6);
  const TriangleMesh sphere = makeSphere(0.05);
  EXPECT_NEAR(sphere.minCorner().z(), 0.0, 1e-6);
  EXPECT_NEAR(sphere.maxCorner().z(), 0.1, 1e-6);
  const TriangleMesh racket = makeExtrusion({ { -0.1, -0.05 }, { 0.1, -0.05 }, { 0.1, 0.05 }, { -0.1, 0.05 } }, 0.02);
  EXPECT_NEAR(racket.maxCorner().z(), 0.02, 1e-6);
  EXPECT_NEAR(racket.maxCorner().x(), 0.1, 1e-6);
  // A cylinder seen from above at 1 m: its top disc covers pi r^2 f^2 / z^2 pixels.
  ScenePart can;
  can.mesh = cylinder;
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translate(Eigen::Vector3f(0.0f, 0.0f, 1.2f));
  pose.rotate(Eigen::AngleAxisf(static_cast<float>(kPi), Eigen::Vector3f::UnitX()));  // top toward the camera
  can.mesh.transform(pose);
  XtionNoiseParams no_shadow;
  no_shadow.projector_shadows = false;
  const RenderedFrame frame = XtionRenderer({ can }, XtionIntrinsics(), no_shadow).renderNoiseFree(kIdentityCamera);
  const double expected_px = kPi * 0.03 * 0.03 * 570.3422 * 570.3422 / (1.0 * 1.0);
  EXPECT_NEAR(static_cast<double>(frame.validCount()), expected_px, 0.03 * expected_px);
}

TEST(XtionRenderer, LookAtPoseUsesOpticalConvention)
{
  const Eigen::Quaterniond q = opticalFromLinkRotation();
  EXPECT_NEAR(std::abs(q.x()), 0.5, 1e-9);
  EXPECT_NEAR(q.x() * q.w(), -0.25, 1e-9);  // (-0.5, 0.5, -0.5, 0.5) up to overall sign
  EXPECT_NEAR(q.y() * q.w(), 0.25, 1e-9);
  EXPECT_NEAR(q.z() * q.w(), -0.25, 1e-9);
  // Camera above and behind a point, looking at it: optical z points to the target, y down-ish.
  const Eigen::Isometry3d pose = lookAtOpticalPose(Eigen::Vector3d(0.0, 0.0, 0.5), Eigen::Vector3d(0.5, 0.0, 0.0));
  const Eigen::Vector3d z = pose.linear().col(2), x = pose.linear().col(0), y = pose.linear().col(1);
  EXPECT_TRUE(z.isApprox(Eigen::Vector3d(1.0, 0.0, -1.0).normalized(), 1e-9));
  EXPECT_TRUE(x.isApprox(Eigen::Vector3d(0.0, -1.0, 0.0), 1e-9));  // image right = world -y
  EXPECT_LT(y.z(), 0.0);
  // The target projects to the principal point.
  const Eigen::Vector3d target_cam = pose.inverse() * Eigen::Vector3d(0.5, 0.0, 0.0);
  EXPECT_NEAR(target_cam.x(), 0.0, 1e-9);
  EXPECT_NEAR(target_cam.y(), 0.0, 1e-9);
}

TEST(XtionRenderer, MissingMeshFileIsReportedNotThrown)
{
  TriangleMesh mesh;
  std::string error;
  EXPECT_FALSE(loadMeshFile("/nonexistent/mesh.stl", mesh, error));
  EXPECT_FALSE(error.empty());
}

/// A fuzz corpus input of the mesh_loader target (one format byte, then the file) written as
/// the file `name` (its extension picks the reader).
std::string meshFromCorpus(const std::string& corpus_file, const std::string& name,
                           const std::function<void(std::string&)>& edit = {})
{
  std::ifstream in(std::string(FAST_GRASP_SOURCE_DIR) + "/test/fuzz/corpus/mesh_loader/" + corpus_file,
                   std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_FALSE(bytes.empty()) << corpus_file;
  bytes.erase(0, 1);
  if (edit)
    edit(bytes);
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

TEST(XtionRenderer, StlFormatIsDecidedBeforeVtkReadsIt)
{
  TriangleMesh ascii, binary, mesh;
  std::string error;
  ASSERT_TRUE(loadMeshFile(meshFromCorpus("seed_box_ascii.stl", "box_ascii.stl"), ascii, error)) << error;
  ASSERT_TRUE(loadMeshFile(meshFromCorpus("seed_box_binary.stl", "box_binary.stl"), binary, error)) << error;
  EXPECT_EQ(ascii.triangles.size(), 12u);
  EXPECT_EQ(binary.triangles.size(), 12u);
  // Binary exporters often start the 80-byte header with "solid": the size decides.
  const std::string solid_header = meshFromCorpus("seed_box_binary.stl", "box_binary_solid_header.stl",
                                                     [](std::string& b) { b.replace(0, 5, "solid"); });
  ASSERT_TRUE(loadMeshFile(solid_header, mesh, error)) << error;
  EXPECT_EQ(mesh.triangles.size(), 12u);
  // The fuzzer's file: "solid", then binary bytes; VTK read it as binary and allocated 18 GB.
  error.clear();
  EXPECT_FALSE(loadMeshFile(meshFromCorpus("crash_stl_solid_but_binary", "solid_but_binary.stl"), mesh, error));
  EXPECT_NE(error.find("starts like an ASCII STL ('solid') but holds binary bytes"), std::string::npos) << error;
  // A binary STL declaring one triangle more than it holds.
  const std::string short_binary = meshFromCorpus("seed_box_binary.stl", "box_binary_short.stl", [](std::string& b) {
    const std::uint32_t triangles = 13;
    std::memcpy(&b[80], &triangles, sizeof(triangles));
  });
  EXPECT_FALSE(loadMeshFile(short_binary, mesh, error));
  EXPECT_NE(error.find("nor a binary one (684 bytes, not 84 + 50 x the 13 triangles"), std::string::npos) << error;
}

/// `text` as the file <temp>/<file_name>; its path.
std::string writeMeshFile(const std::string& file_name, const std::string& text)
{
  const std::string path = ::testing::TempDir() + "/" + file_name;
  std::ofstream(path) << text;
  return path;
}

TEST(XtionRenderer, ObjFaceIndicesAreCheckedBeforeVtkReadsThem)
{
  // VTK 9.1's OBJ reader dereferences a null texture-coordinate array for "v/vt" without any
  // "vt" line (the fuzzer's file: "f 1 2 4/ 3"); with the texture coordinates it reads.
  TriangleMesh mesh;
  std::string error;
  const std::string vertices = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\n";
  EXPECT_FALSE(loadMeshFile(writeMeshFile("texture_without_vt.obj", vertices + "f 1 2/1 3\n"), mesh, error));
  EXPECT_NE(error.find("face vertex '2/1' names texture coordinate 1 of 0"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("empty_texture.obj", vertices + "f 1 2/ 3\n"), mesh, error));
  EXPECT_NE(error.find("is not v, v/vt, v/vt/vn or v//vn"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("vertex_out_of_range.obj", vertices + "f 1 2 4\n"), mesh, error));
  EXPECT_NE(error.find("names vertex 4 of 3"), std::string::npos) << error;
  ASSERT_TRUE(loadMeshFile(writeMeshFile("with_texture.obj", vertices + "vt 0 0\nvt 1 0\nf 1/1 2/2 3/1\n"), mesh, error)) << error;
  EXPECT_EQ(mesh.triangles.size(), 1u);
  error.clear();
  // The fuzzer's file is refused before VTK reads it (since session 15 already for its short
  // vertex lines, which come before the face).
  EXPECT_FALSE(loadMeshFile(meshFromCorpus("crash_obj_texture_index_without_vt", "fuzzed.obj"), mesh, error));
  EXPECT_NE(error.find("fuzzed.obj"), std::string::npos) << error;
}

TEST(XtionRenderer, PlyListsOutsideTheFaceElementAreRefusedBeforePclReadsThem)
{
  // PCL's PLYReader asserts (aborts the process) on a list property of the vertex element.
  TriangleMesh mesh;
  std::string error;
  const std::string vertex = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\n";
  const std::string body = "0 0 0\n0.1 0 0\n0 0.1 0\n3 0 1 2\n";
  EXPECT_FALSE(loadMeshFile(writeMeshFile("list_on_vertex.ply", vertex + "property list uchar int vertex_indices\nend_header\n" + body),
                            mesh, error));
  EXPECT_NE(error.find("a list property in element 'vertex'"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("negative_count.ply", vertex + "element face -5\nend_header\n" + body), mesh,
                            error));
  EXPECT_NE(error.find("element 'face' has count '-5'"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(meshFromCorpus("crash_ply_negative_count", "fuzzed_count.ply"), mesh, error));
  EXPECT_NE(error.find("has count '-5'"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("no_end.ply", vertex), mesh, error));
  EXPECT_NE(error.find("no end_header"), std::string::npos) << error;
  error.clear();
  EXPECT_FALSE(loadMeshFile(meshFromCorpus("crash_ply_list_on_vertex", "fuzzed.ply"), mesh, error));
  EXPECT_NE(error.find("a list property in element 'vertex'"), std::string::npos) << error;
  ASSERT_TRUE(loadMeshFile(writeMeshFile("triangle.ply", vertex + "element face 1\nproperty list uchar int vertex_indices\nend_header\n" + body),
                           mesh, error))
      << error;
  EXPECT_EQ(mesh.triangles.size(), 1u);
}

TEST(XtionRenderer, ObjNormalsNoFaceNamesMustBeOnePerVertex)
{
  // Fewer "vn" lines than vertices and no face naming one: VTK keeps them as per-vertex normals
  // and PCL's vtk2mesh copies one per vertex, past the array's end (heap overflow found by
  // fuzzing, session 15). Normals that faces name, or one per vertex, read fine.
  TriangleMesh mesh;
  std::string error;
  const std::string vertices = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\n";
  EXPECT_FALSE(loadMeshFile(writeMeshFile("one_loose_normal.obj", vertices + "vn 0 0 1\nf 1 2 3\n"), mesh, error));
  EXPECT_NE(error.find("1 normal(s) for 3 vertices"), std::string::npos) << error;
  ASSERT_TRUE(loadMeshFile(writeMeshFile("named_normal.obj", vertices + "vn 0 0 1\nf 1//1 2//1 3//1\n"), mesh, error)) << error;
  ASSERT_TRUE(loadMeshFile(writeMeshFile("normal_per_vertex.obj", vertices + "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1 2 3\n"), mesh, error))
      << error;
  EXPECT_EQ(mesh.triangles.size(), 1u);
  error.clear();
  // The fuzzer's files are refused before VTK reads them, whichever rule comes first.
  for (const char* fuzzed : { "crash_obj_fewer_normals_than_vertices", "crash_obj_nul_in_keyword" })
  {
    error.clear();
    EXPECT_FALSE(loadMeshFile(meshFromCorpus(fuzzed, "fuzzed.obj"), mesh, error)) << fuzzed;
    EXPECT_NE(error.find("fuzzed.obj"), std::string::npos) << error;
  }
  // The rerun's find: "vn\0..." is a normal to VTK, not to a word count; and short v/vn lines.
  EXPECT_FALSE(loadMeshFile(writeMeshFile("nul_keyword.obj", vertices + std::string("vn\0 0 1\n", 9) + "f 1 2 3\n"), mesh, error));
  EXPECT_NE(error.find("control byte"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("short_vertex.obj", "v 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n"), mesh, error));
  EXPECT_NE(error.find("'v' line with 2 number(s)"), std::string::npos) << error;
  EXPECT_FALSE(loadMeshFile(writeMeshFile("short_normal.obj", vertices + "vn 0\nf 1//1 2//1 3//1\n"), mesh, error));
  EXPECT_NE(error.find("'vn' line with 1 number(s)"), std::string::npos) << error;
}

}  // namespace fast_grasp
