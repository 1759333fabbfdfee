// Clusters merged by group, for the segmentation's joins (occlusion_join.h, neck_join.h): each
// finds which clusters are one object, this puts them together the one way the rest of the
// segmentation expects (largest first, every point in exactly one cluster). ROS-free.
#pragma once

#include <pcl/PointIndices.h>

#include <vector>

namespace fast_grasp
{
/// Merges the clusters that share a group (`group_of[c]`: any id, one per object) into one
/// cluster each: in the order their groups first appear, their points in cluster order, the
/// header of the first; then returns them largest first (stable). `joined_into[c]`, when given,
/// receives for each input cluster the index of the output cluster that holds it.
std::vector<pcl::PointIndices> mergeClusterGroups(const std::vector<pcl::PointIndices>& clusters,
                                                  const std::vector<int>& group_of, std::vector<int>* joined_into);

}  // namespace fast_grasp
