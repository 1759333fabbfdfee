// The geometry a grasp's fate depends on, as numbers a success model can weigh: where the
// fingers close against the object's height and centre of mass, how the contact surfaces face
// the fingers, how much finger is on the object, how close the hand comes to the table.
// Beyond the thesis (its planners score each by their own metric, which are not comparable):
// the fused planner ranks every planner's candidates with one logistic model over these
// features, fitted to physics outcomes (scripts/fit_fused_model.py). ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <Eigen/Core>

#include <string>
#include <utility>
#include <vector>

namespace fast_grasp
{
/// What the features need to know about the object once per view.
struct ObjectExtent
{
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  float height_m = 0.0f;      // highest point above the table (or above the lowest point)
  float max_extent_m = 0.0f;  // largest side of the axis-aligned bounding box (0: no finite point)
  Eigen::Vector3f box_min = Eigen::Vector3f::Zero();  // the axis-aligned bounding box's corners
  Eigen::Vector3f box_max = Eigen::Vector3f::Zero();
  Eigen::Vector3f up = Eigen::Vector3f::UnitZ();  // away from the table (against gravity)
  float table_offset = 0.0f;  // height above table = up . p + table_offset
  /// Footprint on the table: the seen points' major horizontal axis (2-D PCA in the table
  /// plane), their extent along it and across it. With the height, the footprint's box stands
  /// in for the object's weight (the unseen back is missing: a lower bound).
  Eigen::Vector3f major_axis = Eigen::Vector3f::UnitX();
  float length_m = 0.0f;
  float breadth_m = 0.0f;
  float centroid_height_m() const { return up.dot(centroid) + table_offset; }
};

ObjectExtent objectExtent(const ObjectView& view);

/// Two unit vectors spanning the plane perpendicular to `up` (the table plane's axes).
std::pair<Eigen::Vector3f, Eigen::Vector3f> tablePlaneBasis(const Eigen::Vector3f& up);

/// Feature names, in the order graspFeatures() returns them and the model's weights use.
/// The first ones are one-hot sources: from_<planner> for the candidate's planner.
const std::vector<std::string>& graspFeatureNames();

/// Candidate sources the one-hot features know ("principal_axis", ..., "top_down", "side",
/// "end" for the fused planner's end-on grasps).
const std::vector<std::string>& graspFeatureSources();

/// A seen point between a grasp's open fingers: where it is in the grasp frame (X approach,
/// Y closing, Z across the fingers) and its normal (zero where the view has none).
struct PointBetweenFingers
{
  Eigen::Vector3f local;
  Eigen::Vector3f normal;
};

/// The view's points in the closing region at full opening, centred on the grasp: within
/// finger_depth_m / 2 along X, max_opening_m / 2 along Y, finger_width_m / 2 along Z. What the
/// fingers will squeeze; the ones nearest each finger are the contacts.
std::vector<PointBetweenFingers> pointsBetweenOpenFingers(const GraspCandidate& grasp, const GripperModel& gripper,
                                                          const CloudNormal& cloud);

/// The features of `grasp` (pose already fitted by the gripper-volume check) on `view`.
/// `source` is the candidate's planner (one of graspFeatureSources(); another sets no one-hot).
std::vector<double> graspFeatures(const GraspCandidate& grasp, const std::string& source, const ObjectView& view,
                                  const ObjectExtent& extent, const GripperModel& gripper);

/// Logistic success model: p = 1 / (1 + exp(-(bias + weights . features))).
struct GraspSuccessModel
{
  double bias = 0.0;
  std::vector<double> weights;  // graspFeatureNames() order; empty = every weight 0
  std::string fitted_on;        // provenance line written by scripts/fit_fused_model.py

  double probability(const std::vector<double>& features) const;
  std::string validate() const;
};

}  // namespace fast_grasp
