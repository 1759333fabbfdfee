// Clusters merged by group, for the segmentation's joins (occlusion_join.h, neck_join.h,
// container_join.h): each finds which clusters are one object, this puts them together the one
// way the rest of the segmentation expects (largest first, every point in exactly one cluster);
// and the clusters' footprints on the table, which the table-frame joins judge. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <limits>
#include <optional>
#include <vector>

namespace fast_grasp
{
/// Merges the clusters that share a group (`group_of[c]`: any id, one per object) into one
/// cluster each: in the order their groups first appear, their points in cluster order, the
/// header of the first; then returns them largest first (stable). `joined_into[c]`, when given,
/// receives for each input cluster the index of the output cluster that holds it.
std::vector<pcl::PointIndices> mergeClusterGroups(const std::vector<pcl::PointIndices>& clusters,
                                                  const std::vector<int>& group_of, std::vector<int>* joined_into);

/// The table's frame the joins judge clusters in: `up` (the plane's unit normal), two
/// horizontal axes, and the height of a point above the plane.
struct TableAxes
{
  Eigen::Vector3f up, e1, e2;
  float offset = 0.0f;  // height(p) = up . p + offset

  float height(const Eigen::Vector3f& p) const { return up.dot(p) + offset; }
  Eigen::Vector2f horizontal(const Eigen::Vector3f& p) const { return { e1.dot(p), e2.dot(p) }; }
};

/// The axes of the plane a*x + b*y + c*z + d = 0; nullopt when (a, b, c) has no length (zero or NaN).
std::optional<TableAxes> tableAxes(const Eigen::Vector4f& plane);

/// One cluster seen from above the table: each point's horizontal coordinates (cluster order),
/// their mean, and the lowest and highest point's height (+-infinity when empty).
struct ClusterFootprint
{
  std::vector<Eigen::Vector2f> points;
  Eigen::Vector2f mean = Eigen::Vector2f::Zero();
  float low = std::numeric_limits<float>::infinity();
  float top = -std::numeric_limits<float>::infinity();
};

std::vector<ClusterFootprint> clusterFootprints(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                const TableAxes& table);

}  // namespace fast_grasp
