// Core grasp-planning types shared by every planner. ROS-free: C++17, Eigen, PCL.
#pragma once

#include "fast_grasp/core/gripper_model.h"

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
using PointXYZ = pcl::PointXYZ;
using PointNormal = pcl::PointNormal;
using CloudXYZ = pcl::PointCloud<PointXYZ>;
using CloudNormal = pcl::PointCloud<PointNormal>;

/// What a grasp planner sees of one object: everything in the robot base frame.
struct ObjectView
{
  /// Object points with unit normals oriented toward the sensor. Must not be null.
  CloudNormal::ConstPtr cloud;
  /// Optical centres of the camera(s) that saw the object (one, or two in Ch3.5 mode).
  std::vector<Eigen::Vector3f> sensor_origins;
  /// Supporting plane a*x + b*y + c*z + d = 0 with (a, b, c) unit, pointing away from the table.
  Eigen::Vector4f table_plane{ 0.0f, 0.0f, 1.0f, 0.0f };
  bool has_table_plane = false;
  /// Unit gravity direction.
  Eigen::Vector3f gravity{ 0.0f, 0.0f, -1.0f };
  /// Points the open hand must stay out of besides the object's own (and its unseen part): the
  /// other objects on the table and the space hidden behind them (grasping/table_grasps.h).
  /// Null for a single object. The planners' hand checks treat them as their unseen part.
  std::shared_ptr<const CloudXYZ> obstacles;
};

/// One grasp (named GraspCandidate because the ROS message fast_grasp::GraspCandidate shares the
/// namespace). Frame convention (DESIGN.md): origin at the centre of the closing region,
/// X = approach (hand into object), Y = closing direction, Z = X x Y.
struct GraspCandidate
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double width_m = 0.0;
  double score = 0.0;  // higher is better
  static constexpr double kUnset = std::numeric_limits<double>::quiet_NaN();
  double force_balance_rad = kUnset;
  double xoz_offset_m = kUnset;
  double variance_m = kUnset;
  double torque_offset_m = kUnset;
  double gravity_offset_m = kUnset;
  std::string algorithm;
  /// The two contact points (base frame), when the algorithm knows them.
  Eigen::Vector3d contact_a = Eigen::Vector3d::Constant(kUnset);
  Eigen::Vector3d contact_b = Eigen::Vector3d::Constant(kUnset);
  /// The fused planner's success-model features (grasping/grasp_features.h order); else empty.
  std::vector<double> features;
  /// The hold check expects this grasp to drop (grasping/hold_check.h: below a tall object's
  /// centre of mass, short of a lying round object's axis, ...). The fused planner keeps such a
  /// grasp after every other one instead of dropping it; its score stays the model's.
  bool drop_risk = false;

  Eigen::Vector3d position() const { return pose.translation(); }
  Eigen::Vector3d approach() const { return pose.linear().col(0); }
  Eigen::Vector3d binormal() const { return pose.linear().col(1); }  // closing direction
  Eigen::Vector3d axis() const { return pose.linear().col(2); }
};

/// Builds a right-handed grasp pose from an approach and a closing direction
/// (the closing direction is re-orthogonalised against the approach).
Eigen::Isometry3d makeGraspPose(const Eigen::Vector3d& centre, const Eigen::Vector3d& approach,
                                const Eigen::Vector3d& closing);

enum class GraspFailure
{
  None,
  EmptyInput,        // no points at all, or no finite point
  DegenerateInput,   // too few points, collinear, flat: no frame or hull can be built
  NoGraspableZone,   // nothing fits inside the gripper opening
  NoStableGrasp,     // candidates exist but none passes the stability / collision checks
  Timeout,           // the time budget ran out before any grasp passed
  InvalidParameters  // the gripper or parameters make planning impossible
};

const char* toString(GraspFailure failure);

/// Output of every planner: grasps best first, or a typed failure with a readable reason,
/// plus the intermediate products worth drawing.
struct GraspResult
{
  std::vector<GraspCandidate> grasps;  // sorted by score, best first; empty iff failure != None
  GraspFailure failure = GraspFailure::None;
  std::string message;  // human-readable reason (or a summary on success)
  double compute_time_s = 0.0;
  std::size_t candidates_evaluated = 0;

  // Intermediate products (base frame) for markers and debugging; any may be empty.
  CloudXYZ hull;            // boundary / hull contour
  CloudXYZ graspable_zone;  // e.g. Ch3 crossing points within the opening
  std::vector<GraspCandidate> candidates;  // evaluated candidates, with their scores
  CloudXYZ unseen;          // Ch6 unseen-part obstacle points
  /// Ch3.2.3: suggested next sensor pose when no grasp passes.
  std::optional<Eigen::Isometry3d> next_view;

  bool ok() const { return failure == GraspFailure::None && !grasps.empty(); }
  static GraspResult fail(GraspFailure why, std::string message)
  {
    GraspResult result;
    result.failure = why;
    result.message = std::move(message);
    return result;
  }
};

/// Every grasp algorithm implements this one interface. Algorithm parameters are given to
/// the planner's constructor, so one planner object serves many views; plan() is const and
/// thread-safe.
class GraspPlanner
{
public:
  virtual ~GraspPlanner() = default;
  virtual GraspResult plan(const ObjectView& view, const GripperModel& gripper) const = 0;
  virtual const char* name() const = 0;  // "principal_axis", "cshape", ...
};

/// Sorts grasps best first (highest score; ties broken by smaller force balance).
void sortGraspsBestFirst(std::vector<GraspCandidate>& grasps);

/// Monotonic stopwatch for time budgets.
class Stopwatch
{
public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double elapsedSeconds() const
  {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace fast_grasp
