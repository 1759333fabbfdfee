// Test helper: single-view point clouds of analytic shapes, as one depth camera at a known
// optical centre would see them (only the surfaces facing the camera, nearest hit per ray,
// so shapes occlude each other), with unit normals oriented toward the camera.
// Shared by the planner tests; ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Geometry>

#include <vector>

namespace fast_grasp
{
namespace synthetic
{
/// A solid primitive in the base frame. Local frames: a box is centred at the pose origin
/// with full edge lengths `size_m`; a cylinder is centred at the pose origin with its axis
/// along local Z (size_m = {radius, radius, height}); a sphere has radius size_m.x().
struct Shape
{
  enum class Kind
  {
    Box,
    Cylinder,
    Sphere
  };
  Kind kind = Kind::Box;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d size_m = Eigen::Vector3d::Constant(0.05);
};

Shape makeBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& edge_lengths_m,
              const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity());
/// Cylinder whose axis is `axis` (normalised inside), centred at `centre` (mid-height).
Shape makeCylinder(const Eigen::Vector3d& centre, const Eigen::Vector3d& axis, double radius_m, double height_m);
Shape makeSphere(const Eigen::Vector3d& centre, double radius_m);

/// How the camera samples the scene.
struct ViewParams
{
  /// Camera optical centre (base frame); the camera looks at the centre of the shapes'
  /// bounding sphere.
  Eigen::Vector3d viewpoint = Eigen::Vector3d(0.0, 0.0, 1.0);
  /// Ray spacing measured on the plane through the look-at point perpendicular to the view
  /// direction, i.e. roughly the point spacing on surfaces facing the camera.
  double spacing_m = 0.002;
  /// Gaussian noise added along each ray (depth noise), 0 for none.
  double noise_stddev_m = 0.0;
  unsigned noise_seed = 1;
  /// A surface meeting the ray more obliquely than this returns no point, as with a depth
  /// camera (the Xtion's 70 deg, xtion_renderer.h); 0 = every hit is returned.
  double max_incidence_rad = 0.0;
};

/// Casts one ray per grid cell from the viewpoint and keeps the nearest hit on any shape.
/// Returns an unorganised dense cloud (possibly empty if the viewpoint is inside a shape or
/// nothing is hit); normals are unit and point toward the viewpoint.
CloudNormal::Ptr renderView(const std::vector<Shape>& shapes, const ViewParams& view);
CloudNormal::Ptr renderView(const Shape& shape, const ViewParams& view);

/// Convenience: an ObjectView with `cloud` and a single sensor origin.
ObjectView makeObjectView(const CloudNormal::ConstPtr& cloud, const Eigen::Vector3d& viewpoint);

/// A gripper with the Robotiq 2F-85's opening and finger width (85 mm, 22 mm; 2 mm minimum),
/// every other field at GripperModel's defaults: the hand of the analytic planner tests.
GripperModel robotiqLikeGripper();

/// The points of `cloud` without their normals.
CloudXYZ toXyz(const CloudNormal& cloud);

/// Ray-shape intersection (exposed for tests of the helper itself): returns true and the
/// nearest positive ray parameter `t` and the outward unit normal at the hit.
bool intersectRay(const Shape& shape, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                  double& t, Eigen::Vector3d& normal);

}  // namespace synthetic
}  // namespace fast_grasp
