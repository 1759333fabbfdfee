// Joins the visible pieces of one object that a nearer object cuts in two. Beyond the thesis (it
// segments one isolated object). ROS-free.
//
// A box standing behind a bottle shows a piece left and a piece right of it; Euclidean
// clustering sees two objects, and a planner would grasp a piece as if it were the whole box.
// Two pieces are one object when the camera saw nothing between them: of the points sampled on
// the segment between the pieces' closest points, none is seen (nothing else lies at or behind
// it along the camera's line of sight, as the table behind a gap would), at least half are
// hidden (something else lies nearer: the occluder) and the rest fall in a shadow without
// return; and their tops are at one height above the table. Objects standing apart show the
// gap between them and stay apart; two objects that touch behind an occluder and share their
// top height are the case this rule gets wrong.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <vector>

namespace fast_grasp
{
struct OcclusionJoinParams
{
  /// Pieces whose closest points are farther apart than this are never one object (the widest
  /// occluder a hidden part may span).
  double max_gap_m = 0.15;
  /// The pieces' highest points above the table must differ by less than this.
  double max_top_difference_m = 0.01;
  /// Spacing of the sampled points between the pieces.
  double sample_step_m = 0.005;
  /// A sample is hidden when a point of another cluster, the table or the background lies at
  /// least this much nearer the camera within one angular cell of its line of sight.
  double hidden_margin_m = 0.01;
  /// Angular cell of the occluders' depth map, in the camera's image plane (tan of the angle):
  /// 0.006 is 6 mm at 1 m, above the 5 mm voxels so that a seen surface has no holes.
  double angular_cell = 0.006;
};

/// Joins pieces of `clusters` (indices into `cloud`) that the rule above finds to be one object
/// hidden in its middle by another cluster (only with three clusters or more). `camera_position` and
/// `camera_orientation` are the sensor's pose in the cloud's frame (its optical axis is +z);
/// `plane` is the table (a, b, c, d, normal up). Returns the clusters, largest first; every
/// input point stays in exactly one cluster. `joined_into[c]`, when given, receives for each
/// input cluster the index of the output cluster that holds it.
std::vector<pcl::PointIndices> joinOccludedPieces(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                  const Eigen::Vector3f& camera_position,
                                                  const Eigen::Quaternionf& camera_orientation,
                                                  const Eigen::Vector4f& plane, const OcclusionJoinParams& params,
                                                  std::vector<int>* joined_into = nullptr);

}  // namespace fast_grasp
