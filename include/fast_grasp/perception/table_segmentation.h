// Thesis Ch3.2 step 1 / Ch6.2 step 1, second half: RANSAC table plane, removal of the plane
// and of what lies under it, Euclidean clusters, choice of the target object. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/perception/concave_split.h"
#include "fast_grasp/perception/container_join.h"
#include "fast_grasp/perception/neck_join.h"
#include "fast_grasp/perception/occlusion_join.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <cstddef>
#include <string>
#include <vector>

namespace fast_grasp
{
enum class TargetCluster
{
  CenterOfView,    // centroid at the smallest angle from the camera's optical axis (the input's
                   // sensor_origin_ / sensor_orientation_): the object the camera is aimed at
  Nearest,         // centroid nearest to `reference_point_m` (default: the robot base origin)
  Largest,         // most points
  ClosestToPoint   // centroid nearest to `target_point_m`
};

/// Parses "center_of_view" | "nearest" | "largest" | "closest_to_point"; false if unknown.
bool parseTargetCluster(const std::string& text, TargetCluster& out);
const char* toString(TargetCluster target);

struct TableSegmentationParams
{
  /// RANSAC inlier band around the table plane. Xtion axial noise at 1 m is ~3 mm (1 sigma),
  /// so 1 cm keeps nearly all table points.
  double plane_distance_m = 0.01;
  int ransac_max_iterations = 200;
  /// The table is searched among planes whose normal is within this angle of `up_axis`.
  Eigen::Vector3f up_axis{ 0.0f, 0.0f, 1.0f };
  double max_table_tilt_rad = 0.26;  // 15 degrees
  /// Minimum inliers for a plane to count as the table.
  int min_table_points = 200;
  /// Points lower than this above the fitted plane are table (or under it) and never object.
  double min_height_above_table_m = 0.01;
  /// Euclidean clustering of what stands on the table.
  double cluster_tolerance_m = 0.02;
  int min_cluster_points = 10;
  int max_cluster_points = 100000;
  /// Cut each Euclidean cluster at its concave creases (concave_split.h), so touching objects
  /// come out as separate clusters. Normals face the input's sensor_origin_. Off by default: it
  /// also cuts single objects made of convex parts (a drill's chuck, a racket's head).
  bool split_concave_creases = false;
  ConcaveSplitParams concave_split;
  /// Join a container's inside to its outer wall when a gap parts them (container_join.h), after
  /// the split (with or without it); the inward-curving test is concave_split's. Needs the
  /// input's sensor_origin_ (the camera).
  bool join_container_insides = true;
  ContainerJoinParams container_join;
  /// Join the two visible pieces of an object that a nearer object hides in its middle
  /// (occlusion_join.h), after the split. Needs the input's sensor_origin_ and
  /// sensor_orientation_ (the camera pose).
  bool join_occluded_pieces = true;
  OcclusionJoinParams occlusion_join;
  /// Join a lying bottle's neck, cut off at its hidden shoulder, to its body (neck_join.h), after
  /// the occlusion join. On since session 32: a heavy bottle's neck, picked as an object of its
  /// own, never held (clutter training piles: 0 of 10 wine-bottle necks); joined, the body is
  /// grasped from its end instead (docs/clutter.md "A lying bottle's neck joined again").
  bool join_lying_necks = true;
  NeckJoinParams neck_join;
  TargetCluster target = TargetCluster::CenterOfView;
  /// Clusters stacked on the target (their projection onto the table lies mostly over the
  /// target's footprint) are parts of it that a gap split off: a transparent neck, a thin stem
  /// lost to noise. Nothing floats, so they are merged into the object. Only clusters a gap
  /// separated are merged: pieces that a concave crease cut from the target's Euclidean cluster
  /// (a box standing on a box) stay apart.
  bool merge_stacked_clusters = true;
  /// Fraction of a cluster's points that must project within cluster_tolerance_m of the
  /// target's footprint for it to be merged.
  double stacked_overlap_fraction = 0.5;
  Eigen::Vector3f reference_point_m = Eigen::Vector3f::Zero();  // for Nearest
  Eigen::Vector3f target_point_m = Eigen::Vector3f::Zero();     // for ClosestToPoint
  /// The chosen object's centroid must lie within this distance of `reference_point_m`
  /// (the arm's reach); <= 0 disables the check.
  double max_object_distance_m = 0.85;
};

enum class SegmentationFailure
{
  None,
  InvalidInput,     // null / empty / non-finite cloud, bad parameters
  NoPlane,          // no plane with enough inliers within the allowed tilt
  NoCluster,        // nothing above the table forms a cluster
  ObjectOutOfReach  // the chosen cluster lies beyond max_object_distance_m
};
const char* toString(SegmentationFailure failure);

struct TableSegmentationResult
{
  SegmentationFailure failure = SegmentationFailure::None;
  std::string reason;
  bool ok() const { return failure == SegmentationFailure::None; }

  /// a, b, c, d with a*x + b*y + c*z + d = 0, (a, b, c) unit and along up_axis. Valid when a plane was found.
  Eigen::Vector4f plane = Eigen::Vector4f::Zero();
  bool has_plane = false;
  /// All clouds keep the input's sensor_origin_ and sensor_orientation_; never null.
  CloudXYZ::Ptr table;   // plane inliers
  CloudXYZ::Ptr object;  // the chosen cluster (empty unless ok)
  CloudXYZ::Ptr scene;   // every input point but the object's (collision environment)
  /// Into the input cloud, largest first; clusters merged into the target are removed and
  /// their points appended to clusters[target_index].
  std::vector<pcl::PointIndices> clusters;
  int target_index = -1;  // into clusters, -1 if none chosen
  int merged_clusters = 0;  // how many stacked clusters were merged into the target
  Eigen::Vector3f object_centroid = Eigen::Vector3f::Zero();
  Eigen::Vector3f object_min = Eigen::Vector3f::Zero();  // axis-aligned bounds, base frame
  Eigen::Vector3f object_max = Eigen::Vector3f::Zero();
  /// Wall time of the two expensive steps (for bench_perception and diagnostics).
  double ransac_time_s = 0.0;      // plane fit and the height classification
  double clustering_time_s = 0.0;  // Euclidean clustering and target choice
};

/// Finds the table, removes it and everything under it, clusters the rest and picks the target.
/// Never throws on bad input; failures come back typed with a reason (and the products
/// computed so far, e.g. the plane when only the clustering failed).
TableSegmentationResult segmentTable(const CloudXYZ::ConstPtr& cloud, const TableSegmentationParams& params);

/// Every cluster of `result` (segmented from `cloud`) in one cloud, each point labelled with its
/// object: the target 0, the other clusters 1, 2, ... in `result.clusters` order. Header and
/// sensor pose are the input's. Empty unless result.ok(). What the planners need to grasp every
/// object on the table (grasping/table_grasps.h), published by TableSegmentation as ~objects.
pcl::PointCloud<pcl::PointXYZL>::Ptr labelledObjects(const CloudXYZ& cloud, const TableSegmentationResult& result);

}  // namespace fast_grasp
