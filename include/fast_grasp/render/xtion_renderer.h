// Xtion-style depth renderer: ray casts triangle scenes into organized 640x480 clouds with
// the structured-light sensor's noise and failure modes. ROS-free core of the render_bag tool.
//
// Noise model (per pixel, in this order):
//  - lateral noise: the depth is sampled at the pixel centre jittered by N(0, 0.8 px)
//    (Nguyen, Izadi, Lovell 2012), then back-projected at the integer pixel, as a registered
//    depth image does;
//  - NaN when the ray hits nothing, a transparent surface, a point outside [0.5, 3.5] m, a surface
//    seen beyond ~70 degrees incidence, or a point the projector (7.5 cm along +x of the IR
//    camera) cannot light (shadow beside foreground edges), plus a small random dropout;
//  - axial noise sigma_z(z, theta) = 0.0012 + 0.0019 (z - 0.4)^2
//                                    + (0.0001 / sqrt(z)) theta^2 / (pi/2 - theta)^2   [m]
//    (Nguyen et al. 2012), applied in disparity space and followed by integer disparity
//    quantisation with 1/Z = -2.85e-3 d + 3 (Khoshelham & Elberink 2012) and rounding to whole
//    millimetres. The Gaussian part is shrunk by the quantisation variance (1/12 px^2) so the
//    total depth noise matches sigma_z; in disparity units it is >= 0.5 px everywhere in range.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Triangle soup. Units are metres; winding does not matter (incidence uses |cos|).
struct TriangleMesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;

  void append(const TriangleMesh& other, const Eigen::Isometry3f& pose = Eigen::Isometry3f::Identity());
  void transform(const Eigen::Isometry3f& pose);
  /// Axis-aligned bounds; both zero for an empty mesh.
  Eigen::Vector3f minCorner() const;
  Eigen::Vector3f maxCorner() const;
};

// Parametric shapes. Each stands on the plane z = 0 of its own frame, centred on the z axis
// (spheres touch z = 0), so placing it on a table is one pose.
TriangleMesh makeBox(double size_x_m, double size_y_m, double size_z_m);
TriangleMesh makeCylinder(double radius_m, double height_m, int segments = 48);
TriangleMesh makeSphere(double radius_m, int segments = 32);
/// Solid of revolution about z of the polyline profile (z_m, radius_m), in order. A profile that
/// goes up the outside and back down the inside gives a hollow vessel (cup, glass, pan).
TriangleMesh makeRevolution(const std::vector<Eigen::Vector2d>& profile_z_r_m, int segments = 48);
/// Flat extrusion of a simple polygon (x_m, y_m) from z = 0 to z = thickness_m (rackets, handles).
/// The polygon must be star-shaped around its vertex centroid (caps are fanned from it).
TriangleMesh makeExtrusion(const std::vector<Eigen::Vector2d>& polygon_xy_m, double thickness_m);

/// Loads STL/OBJ/PLY (through pcl::io::loadPolygonFile). Returns false and sets error on failure.
bool loadMeshFile(const std::string& path, TriangleMesh& mesh, std::string& error);
/// Moves a mesh so its bounding box is centred on the z axis with its lowest point at z = 0
/// (YCB scans have their origin near, not at, the base centre). Returns the applied shift.
Eigen::Vector3f centreOnBase(TriangleMesh& mesh);

/// One rigid piece of a scene, already posed in the world (base_link) frame.
struct ScenePart
{
  TriangleMesh mesh;
  uint8_t red = 128;
  uint8_t green = 128;
  uint8_t blue = 128;
  /// Structured light passes through: pixels that see it first are NaN and it casts no shadow.
  bool transparent = false;
  /// Label written into RenderedFrame::part_label (e.g. 0 = table, 1 = target object).
  int label = 0;
};

struct XtionIntrinsics
{
  int width = 640;
  int height = 480;
  double fx = 570.3422;
  double fy = 570.3422;
  double cx = 319.5;
  double cy = 239.5;
};

struct XtionNoiseParams
{
  bool enable_noise = true;          // false: exact depth (still NaN for range/angle/shadow)
  double min_range_m = 0.5;
  double max_range_m = 3.5;
  double max_incidence_rad = 70.0 * 3.14159265358979323846 / 180.0;
  double lateral_sigma_px = 0.8;
  double disparity_sigma_min_px = 0.5;    // lower bound of the Gaussian disparity noise
  double disparity_per_inverse_m = -2.85e-3;  // 1/Z = disparity_per_inverse_m * d + disparity_offset
  double disparity_offset_inv_m = 3.0;
  bool quantise_disparity = true;
  bool round_depth_to_mm = true;
  double dropout_probability = 0.002;
  /// Projector position in the optical frame of the depth camera (x right).
  double projector_baseline_m = 0.075;
  bool projector_shadows = true;
};

/// Axial noise of Nguyen, Izadi, Lovell (2012); depth in metres, incidence in radians.
double axialNoiseSigma(double depth_m, double incidence_rad);

/// Organized render result in the camera's optical frame (z forward, x right, y down).
struct RenderedFrame
{
  int width = 0;
  int height = 0;
  std::vector<Eigen::Vector3f> points;  // row-major, NaN where the sensor gives no depth
  std::vector<uint32_t> rgb;            // 0x00RRGGBB of whatever the pixel sees (0: nothing)
  std::vector<int> part_label;          // label of the part the pixel sees, -1: nothing

  const Eigen::Vector3f& at(int u, int v) const { return points[static_cast<size_t>(v) * width + u]; }
  int labelAt(int u, int v) const { return part_label[static_cast<size_t>(v) * width + u]; }
  size_t validCount() const;
};

/// Ray casts a static scene through a bounding-volume hierarchy. Build once, render many
/// frames and camera poses. render() is const and thread-compatible (no shared mutable state).
class XtionRenderer
{
public:
  XtionRenderer(std::vector<ScenePart> parts, XtionIntrinsics intrinsics = XtionIntrinsics(),
                XtionNoiseParams noise = XtionNoiseParams());
  ~XtionRenderer();
  XtionRenderer(XtionRenderer&&) noexcept;
  XtionRenderer& operator=(XtionRenderer&&) noexcept;

  /// camera_pose: pose of the optical frame in the world frame. Deterministic for a given seed.
  RenderedFrame render(const Eigen::Isometry3d& camera_pose, uint64_t seed) const;
  /// Same camera, no noise and no dropout: the ground truth the noisy frame approximates.
  RenderedFrame renderNoiseFree(const Eigen::Isometry3d& camera_pose) const;

  const XtionIntrinsics& intrinsics() const { return intrinsics_; }
  const XtionNoiseParams& noise() const { return noise_; }
  size_t triangleCount() const;

private:
  RenderedFrame renderImpl(const Eigen::Isometry3d& camera_pose, uint64_t seed, bool noisy) const;

  struct Bvh;
  std::vector<ScenePart> parts_;
  XtionIntrinsics intrinsics_;
  XtionNoiseParams noise_;
  std::unique_ptr<Bvh> bvh_;
};

/// Optical frame pose for a camera at eye_m looking at target_m, image "up" toward +z of the
/// world (REP 103 camera_link: x forward, y left, z up; optical: z forward, x right, y down).
Eigen::Isometry3d lookAtOpticalPose(const Eigen::Vector3d& eye_m, const Eigen::Vector3d& target_m);
/// Fixed rotation camera_link -> *_optical_frame (quaternion x, y, z, w = -0.5, 0.5, -0.5, 0.5).
Eigen::Quaterniond opticalFromLinkRotation();

}  // namespace fast_grasp
