// Next view of the principal-axis planner (thesis Ch3.2.3, and two cases beyond it): when one
// view yields no grasp but another view of the same object could, the camera is turned about
// the principal axis through the centroid (Eq. 3.6) by an angle that depends on why the plan
// failed. principal_axis_grasp.cpp decides which case applies and picks the points it needs;
// the functions here turn them into a camera pose and the words that explain it.
// ROS-free: C++17, Eigen.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
/// The camera of the failed plan and the axis it turns about: what Eq. 3.6 rotates.
struct CameraAboutAxis
{
  Eigen::Vector3f sensor = Eigen::Vector3f::Zero();     ///< the failed plan's sensor origin
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();   ///< the axis runs through the object's centroid
  Eigen::Vector3f axis = Eigen::Vector3f::UnitY();      ///< unit principal axis (object Y)
  Eigen::Vector3f gravity = -Eigen::Vector3f::UnitZ();  ///< keeps the turned camera's image upright
};

/// A suggested camera pose (REP 103 optical axes: z forward, y down) and why: `reason` is the
/// clause the planner adds to its failure message.
struct NextView
{
  Eigen::Isometry3d camera_pose = Eigen::Isometry3d::Identity();
  std::string reason;
};

/// Eq. 3.6: the look-at pose of a camera at camera.sensor, looking at camera.centroid with its
/// image upright against camera.gravity, turned by `phi` about camera.axis through the centroid.
/// In the object frame of Ch3 a positive phi turns the line of sight Z toward X. Also the
/// table's next view (table_grasps.h), which turns about the table's normal.
Eigen::Isometry3d viewTurnedAboutAxis(const CameraAboutAxis& camera, double phi);

/// Ch3.2.3, the thesis's own rule: every XOY-stable candidate fails XOZ. `best_area_xz` holds
/// the object-frame (x, z) of the points in the finger band of the best XOY candidate; their
/// total-least-squares line is the trace of the main plane. The camera turns to look
/// perpendicular to the main plane when it is narrower than `max_opening_m` (close across its
/// width), else along it (close across its thickness): beta = pi/2 - alpha or alpha, alpha
/// being the angle between the line of sight and the main plane. Always yields a view.
NextView nextViewForXozFailure(const std::vector<Eigen::Vector2d>& best_area_xz, double max_opening_m,
                               const CameraAboutAxis& camera);

/// No graspable zone (thesis risk 2: the gripper cannot cover what it sees). When the seen
/// points clear of the object's ends (`face_xz`, object-frame (x, z)) form one flat face wider
/// than `max_opening_m`, Fig. 3.11 (b)'s rule still applies: looking along the face
/// (beta = alpha) shows the object's thickness instead. Flat means an RMS distance from the
/// face's line below `max_face_rms_ratio` of its width; curved objects (a sphere, a wide can)
/// look as wide from every side, so they get no view (nullopt).
std::optional<NextView> nextViewAlongWideFlatFace(const std::vector<Eigen::Vector2d>& face_xz, double max_opening_m,
                                                  double max_face_rms_ratio, const CameraAboutAxis& camera);

/// Beyond the thesis, which moves the camera only for step 7: stable grasps that the table
/// alone rules out (a low object seen from the side: the hand approaching along the line of
/// sight closes on a tilted line whose lower finger meets the table). The same rotation of
/// Eq. 3.6, as far as it brings the line of sight to vertical, lets the next plan approach from
/// above and close level with the table. `object_x` / `object_z` are the failed plan's object
/// frame axes (closing direction, line of sight). No view (nullopt) when the axis is within
/// `min_axis_view_angle_rad` of vertical (no turn about it looks from above) or the turn is
/// smaller than `min_turn_rad` (the camera already looks from about there).
std::optional<NextView> nextViewFromAbove(const Eigen::Vector3f& up, const Eigen::Vector3f& object_x,
                                          const Eigen::Vector3f& object_z, double min_axis_view_angle_rad,
                                          double min_turn_rad, const CameraAboutAxis& camera);

}  // namespace fast_grasp
