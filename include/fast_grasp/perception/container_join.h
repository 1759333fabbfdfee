// Joins a container's inside to its outer wall when a gap parts them. Beyond the thesis (it
// segments one isolated object). ROS-free.
//
// Seen from above at 40-50 degrees, an open container (a pot, a bowl, a cup) shows the outside
// of its near wall and, over the near rim, the inside of its far wall and its bottom. The side
// walls, where the two surfaces meet, are seen edge-on and return few points, so Euclidean
// clustering often keeps two clusters: the mOSD development scenes learn36 and learn38 each cut a
// pot (and a bowl) this way. The crease split's own container rule (concave_split.h) only sees
// pieces of one cluster. A cluster is the inside of a container when its surface curves inward
// (curvesInward: no object seen from outside does), and its outer wall is the cluster in front
// of it, seen from the camera, that spans the same width across the line of sight, with its top
// at the same height (the rim), and the inside lies behind that wall's front by no more than
// about the container's width (max_depth_to_width).
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/perception/concave_split.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <vector>

namespace fast_grasp
{
struct ContainerJoinParams
{
  /// Across the line of sight, the two clusters' extents overlap by at least this share of the
  /// wider one: an inside and its outer wall span the container's width, a small object in front
  /// of a bowl does not. Above 1: never joined.
  double min_across_overlap = 0.6;
  /// Their highest points above the table (the far and the near rim) differ by at most this.
  double max_top_difference_m = 0.02;
  /// Along the camera's horizontal line of sight the inside ends at most this many times the
  /// container's width (the wider extent across) behind the outer wall's front: a round
  /// container is as deep as it is wide (the pot of learn38, with its rim and handles: 1.13).
  double max_depth_to_width = 1.3;
};

/// Joins each cluster of `clusters` (indices into `cloud`) that the rule above finds to be a
/// container's inside to its outer wall. `viewpoint` is the camera (normals face it), `plane` the
/// table (a, b, c, d, normal up); `bend` holds the normals' neighbourhood (k_neighbours) and the
/// inward-curving test. Returns the clusters, largest first; every input point stays in exactly
/// one cluster. `joined_into[c]`, when given, receives for each input cluster the index of the
/// output cluster that holds it.
std::vector<pcl::PointIndices> joinContainerInsides(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                    const Eigen::Vector3f& viewpoint, const Eigen::Vector4f& plane,
                                                    const ContainerJoinParams& params, const ConcaveSplitParams& bend,
                                                    std::vector<int>* joined_into = nullptr);

}  // namespace fast_grasp
