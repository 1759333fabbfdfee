// The physical gripper as boxes in the grasp frame: the one gripper volume every planner's
// final check uses (test/grasp_checks.py re-implements the same boxes from the same YAML, so
// the tests check the planners against an independent copy). ROS-free.
//
// Each planner models the gripper its own way while it searches (Ch3's contact bands, Ch6's
// C-shape of Eq. 6.1); those models are thinner than the real hand, whose palm stands flat
// behind the fingers. The final check places the open hand at the grasp and, if the palm would
// enter the object, backs the hand out along the approach until it clears, as the real hand
// stops when its palm touches; the grasp is kept only when the fingers still close on the object.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Axis-aligned box in grasp coordinates.
struct GripperBox
{
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  bool contains(const Eigen::Vector3f& p) const
  {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  /// Corner i in [0, 8): bit 0, 1, 2 pick max (set) or min along x, y, z.
  Eigen::Vector3f corner(int i) const
  {
    return { (i & 1) ? max.x() : min.x(), (i & 2) ? max.y() : min.y(), (i & 4) ? max.z() : min.z() };
  }
};

/// The open gripper in grasp coordinates (DESIGN.md: origin at the centre of the closing
/// region, X = approach, Y = closing, Z = X x Y): finger +Y, finger -Y and the palm.
/// Each finger is finger_thickness_m thick along Y starting at +-opening/2, finger_width_m
/// along Z, and spans finger_depth_m along X centred on the origin; the palm is
/// palm_thickness_m deep behind the fingers (X < -finger_depth/2), spans both fingers along Y
/// and palm_width_m (default twice the finger width) along Z.
std::array<GripperBox, 3> openGripperBoxes(const GripperModel& gripper, double opening_m);

/// The space between the fingertips closed to `width_m` (plus `margin_m` per side): the
/// object points there are what the fingers squeeze.
GripperBox closingRegionBox(const GripperModel& gripper, double width_m, double margin_m);

/// How the final gripper-volume check may move a grasp (YAML: `<planner>/gripper_fit/...`).
struct GripperFitParams
{
  /// Check at all (disable only to study a planner's own gripper model).
  bool enabled = true;
  /// Opening of the hand while it approaches; 0 = the gripper's max_opening_m.
  double approach_opening_m = 0.0;
  /// The palm stops this far in front of the nearest obstacle point. The arm planner inflates
  /// its links by link_padding_m (5 mm) and sees points as OctoMap voxels (5 mm), so a palm
  /// nearer than ~1 cm is a collision for it: the default keeps the two consistent.
  double palm_clearance_m = 0.011;
  /// Largest back-off along -approach; deeper conflicts reject the grasp. 0 = half the finger
  /// depth minus 5 mm, so the planned closing line stays between the fingers.
  double max_backoff_m = 0.0;
  /// With a table plane in the view, every corner of the open hand must stay this high above
  /// it; a hand approaching from above is backed out (raised) until it does.
  double table_clearance_m = 0.01;
  /// Seen object points that must lie between the closed fingers after the back-off.
  int min_points_between_fingers = 5;
  /// Y margin of the closing region per side when counting those points.
  double closing_margin_m = 0.005;
  /// A grasp whose open hand the table blocks is turned about its closing line (the contacts
  /// stay where the planner put them) toward an approach from above, in steps of
  /// tilt_step_rad, by at most this much; 0 = never. Beyond the thesis: its planners keep their
  /// approach, and on low objects the table then rejects most of their grasps.
  double max_table_tilt_rad = 1.2;
  double tilt_step_rad = 0.2;
  /// Before fitting, the hand is pushed up to this much further along its approach (in 5 mm
  /// steps, deepest first) and the deepest pose that fits is kept: the palm stops at the
  /// object, more finger is on it and the closing line moves toward the object's middle.
  /// 0 = the planner's depth. Beyond the thesis: fingertip-only closures slipped in physics.
  double max_advance_m = 0.0;
  /// Obstacle points outside the open fingers but within this of them (any face) are counted
  /// in GripperFit::points_grazing_fingers; they do not fail the fit. 0 = not counted. The
  /// fused planner can rank a grasp with such points lower (fused/finger_graze_penalty): in
  /// physics the hand brushed the object with one finger on the approach in 6 of 228 training
  /// trials, all grasps whose exact-box check had passed (sensor noise, the unseen part's guess).
  double finger_graze_margin_m = 0.0;

  std::string validate() const;
};

/// Result of fitting the open gripper at one grasp.
struct GripperFit
{
  bool ok = false;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // the (backed-off) grasp pose
  double backoff_m = 0.0;                // how far the hand was moved along -approach
  std::size_t seen_in_gripper = 0;       // seen points inside the open hand at `pose`
  std::size_t unseen_in_gripper = 0;     // unseen-part points inside it
  std::size_t points_between_fingers = 0;
  std::size_t points_grazing_fingers = 0;  // obstacle points within finger_graze_margin_m of an open finger
  double lowest_above_table_m = 0.0;     // lowest hand corner above the table (inf without one)
  bool blocked_by_table = false;         // rejected because the table is in the way of the open hand
  std::string why;                       // empty when ok
};

/// The obstacles of one view (seen object points, then optional unseen-part points), held in
/// one contiguous array so many grasps can be checked against them cheaply.
class GripperVolumeCheck
{
public:
  GripperVolumeCheck(const GripperModel& gripper, GripperFitParams params);

  template <typename PointT>
  void addSeen(const pcl::PointCloud<PointT>& cloud)
  {
    appendFinite(cloud, seen_);
  }
  void addUnseen(const CloudXYZ& cloud);
  /// The view's neighbouring objects (ObjectView::obstacles), kept out of the hand like the
  /// unseen part; nothing without them.
  void addObstacles(const ObjectView& view);
  /// The supporting plane a x + b y + c z + d = 0 ((a, b, c) need not be unit; the side of
  /// the seen points is "above"). Ignored when not finite or degenerate.
  void setTable(const Eigen::Vector4f& plane);

  /// Places the open hand at `pose`, backs it out until the palm clears (at most
  /// max_backoff_m), and reports whether the hand is then free of every obstacle point and
  /// still has min_points_between_fingers seen points between the fingers closed to `width_m`.
  GripperFit fit(const Eigen::Isometry3d& pose, double width_m) const;

  /// fit() of the grasp pushed deeper (max_advance_m), and where the table blocks the hand, of
  /// the grasp turned about its closing line toward an approach from above
  /// (max_table_tilt_rad): the first that fits, else the plain fit()'s result.
  GripperFit fitOrTilt(const Eigen::Isometry3d& pose, double width_m) const;
  /// fit() of `pose` pushed k * 5 mm along its approach, k from max_advance_m / 5 mm down to 0:
  /// the first that fits, else the plain fit()'s result.
  GripperFit fitDeepest(const Eigen::Isometry3d& pose, double width_m) const;

  /// Applies fitOrTilt() to the grasps in order (best first) until `max_kept` fit: kept grasps get
  /// the fitted pose, the rest are removed. Returns how many were checked and dropped and, in
  /// `why`, the reason of the first dropped one; `blocked_by_table` counts the dropped ones the
  /// table stopped (a planner may then suggest a view from above).
  std::size_t filter(std::vector<GraspCandidate>& grasps, std::string* why = nullptr,
                     std::size_t max_kept = std::numeric_limits<std::size_t>::max(),
                     std::size_t* blocked_by_table = nullptr) const;

  const GripperFitParams& params() const { return params_; }
  /// max_backoff_m, or its automatic value for this gripper.
  double maxBackoff() const;

private:
  /// Appends the finite points of `cloud` as columns of `points`.
  template <typename PointT>
  static void appendFinite(const pcl::PointCloud<PointT>& cloud, Eigen::Matrix3Xf& points)
  {
    Eigen::Index n = points.cols();
    points.conservativeResize(3, n + static_cast<Eigen::Index>(cloud.size()));
    for (const PointT& p : cloud.points)
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
        points.col(n++) = p.getVector3fMap();
    points.conservativeResize(3, n);
  }

  GripperModel gripper_;
  GripperFitParams params_;
  std::array<GripperBox, 3> open_boxes_;
  std::array<GripperBox, 2> graze_boxes_;  // the open fingers grown by finger_graze_margin_m
  Eigen::Matrix3Xf seen_;    // columns: points (matrices, so one product transforms them all)
  Eigen::Matrix3Xf unseen_;
  bool has_table_ = false;
  Eigen::Vector4f table_ = Eigen::Vector4f::Zero();  // unit normal toward the object
};

}  // namespace fast_grasp
