#include "fast_grasp/grasping/principal_axis_next_view.h"

#include "fast_grasp/grasping/grasp_geometry.h"
#include "fast_grasp/grasping/planner_input.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace fast_grasp
{
namespace
{
/// Look-at pose of a camera at `sensor` (REP 103 optical axes: z forward, y down).
Eigen::Isometry3d lookAtPose(const Eigen::Vector3d& sensor, const Eigen::Vector3d& target,
                             const Eigen::Vector3d& gravity)
{
  const Eigen::Vector3d z = (target - sensor).normalized();
  Eigen::Vector3d y = gravity - gravity.dot(z) * z;
  if (y.squaredNorm() < 1e-12)
    y = z.unitOrthogonal();
  y.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = y.cross(z);
  pose.linear().col(1) = y;
  pose.linear().col(2) = z;
  pose.translation() = sensor;
  return pose;
}

/// The main plane of Ch3.2.3 as seen in the XOZ plane: the total-least-squares line through
/// an area's (x, z) points, the area's width along it and the RMS distance of the points from
/// it (small for a flat face, about 0.15 of the width for a seen half cylinder or sphere).
struct MainPlane
{
  Eigen::Vector2d trace = Eigen::Vector2d::UnitX();
  double width_m = 0.0;
  double rms_m = 0.0;
};

MainPlane fitMainPlane(const std::vector<Eigen::Vector2d>& area_xz)
{
  MainPlane plane;
  if (area_xz.size() < 2)
    return plane;
  plane.trace = fitLineDirection(area_xz).normalized();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : area_xz)
    mean += q;
  mean /= static_cast<double>(area_xz.size());
  const Eigen::Vector2d normal(-plane.trace.y(), plane.trace.x());
  double low = std::numeric_limits<double>::infinity(), high = -low, squares = 0.0;
  for (const auto& q : area_xz)
  {
    low = std::min(low, q.dot(plane.trace));
    high = std::max(high, q.dot(plane.trace));
    squares += std::pow((q - mean).dot(normal), 2);
  }
  plane.width_m = high - low;
  plane.rms_m = std::sqrt(squares / static_cast<double>(area_xz.size()));
  return plane;
}

}  // namespace

Eigen::Isometry3d viewTurnedAboutAxis(const CameraAboutAxis& camera, double phi)
{
  const Eigen::Vector3d centre = camera.centroid.cast<double>();
  const Eigen::Isometry3d current = lookAtPose(camera.sensor.cast<double>(), centre, camera.gravity.cast<double>());
  Eigen::Isometry3d about_axis = Eigen::Isometry3d::Identity();
  about_axis.linear() = Eigen::AngleAxisd(phi, camera.axis.cast<double>().normalized()).toRotationMatrix();
  about_axis.translation() = centre - about_axis.linear() * centre;
  return about_axis * current;
}

NextView nextViewForXozFailure(const std::vector<Eigen::Vector2d>& best_area_xz, double max_opening_m,
                               const CameraAboutAxis& camera)
{
  // Main plane: the plane through the principal axis along which the best grasping area
  // extends (its trace in XOZ is the area's total-least-squares line).
  const MainPlane main_plane = fitMainPlane(best_area_xz);
  const Eigen::Vector2d& trace = main_plane.trace;
  const double main_plane_width_m = main_plane.width_m;
  const Eigen::Vector2d sight(0.0, 1.0);  // object Z in (x, z)
  // alpha: angle between the line of sight and the main plane.
  const double alpha = std::acos(std::min(1.0, std::abs(trace.dot(sight))));
  Eigen::Vector2d target;
  double beta = 0.0;
  if (main_plane_width_m < max_opening_m)
  {
    // Look perpendicular to the main plane: the gripper can close across its width.
    target = Eigen::Vector2d(-trace.y(), trace.x());
    beta = M_PI / 2.0 - alpha;
  }
  else
  {
    // Look along the main plane (tangent): close across its thickness instead.
    target = trace;
    beta = alpha;
  }
  if (target.dot(sight) < 0.0)
    target = -target;
  // Rotating about Y by phi maps Z to cos(phi) Z + sin(phi) X; |phi| = beta by construction.
  const double phi = std::atan2(target.x(), target.y());
  NextView next;
  next.camera_pose = viewTurnedAboutAxis(camera, phi);
  next.reason = "next view rotated by beta " + formatNumber(beta) + " rad about the principal axis (alpha " +
                formatNumber(alpha) + " rad, main plane " + formatNumber(main_plane_width_m) + " m)";
  return next;
}

std::optional<NextView> nextViewAlongWideFlatFace(const std::vector<Eigen::Vector2d>& face_xz, double max_opening_m,
                                                  double max_face_rms_ratio, const CameraAboutAxis& camera)
{
  const MainPlane face = fitMainPlane(face_xz);
  if (!(face.width_m > max_opening_m && face.rms_m < max_face_rms_ratio * face.width_m))
    return std::nullopt;
  Eigen::Vector2d target = face.trace;  // (x, z): look along the face
  if (target.y() < 0.0)
    target = -target;
  const double phi = std::atan2(target.x(), target.y());
  NextView next;
  next.camera_pose = viewTurnedAboutAxis(camera, phi);
  next.reason = "the seen face (" + formatNumber(face.width_m) + " m wide, " + formatNumber(face.rms_m * 1000.0) +
                " mm RMS off flat) is wider than the opening: next view along it, rotated by beta = alpha " +
                formatNumber(std::abs(phi)) + " rad about the principal axis";
  return next;
}

std::optional<NextView> nextViewFromAbove(const Eigen::Vector3f& up, const Eigen::Vector3f& object_x,
                                          const Eigen::Vector3f& object_z, double min_axis_view_angle_rad,
                                          double min_turn_rad, const CameraAboutAxis& camera)
{
  // Up made perpendicular to the axis is the line of sight the turn can reach nearest to
  // vertical; phi is its angle from the current line of sight (object Z) toward object X.
  const Eigen::Vector3f up_across = up - up.dot(camera.axis) * camera.axis;
  const double phi = std::atan2(up_across.dot(object_x), up_across.dot(object_z));
  if (!(up_across.norm() > std::sin(min_axis_view_angle_rad) && std::abs(phi) >= min_turn_rad))
    return std::nullopt;
  NextView next;
  next.camera_pose = viewTurnedAboutAxis(camera, phi);
  next.reason = "next view from above, rotated by " + formatNumber(std::abs(phi)) + " rad about the principal axis";
  return next;
}

}  // namespace fast_grasp
