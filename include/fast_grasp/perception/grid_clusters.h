// Euclidean clusters (points joined when closer than a tolerance) found on a voxel grid instead of
// a k-d tree: the same partition as pcl::EuclideanClusterExtraction, faster. ROS-free.
//
// Why hand-written: the budget is 20 ms per 640x480 frame on one core for the whole
// segmentation, and on the mOSD scenes pcl::EuclideanClusterExtraction (one FLANN radius search
// per point, 2 cm on 5 mm voxels) was about 40 % of segmentTable's time, the frame at 19-21 ms
// (perf over bench_segmentation --split all). The grid needs no search: with cells of
// tolerance / sqrt(3), any two points of one cell are within the tolerance, so each occupied
// cell is joined whole; two cells at most two cells apart along each axis are joined when some
// pair of their points is within the tolerance, and that pair is looked for only while the two
// cells are not yet in one cluster (union-find over cells; neighbours one cell away first, so
// most farther pairs are settled before their points are compared).
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <pcl/PointIndices.h>
#include <pcl/types.h>

#include <optional>
#include <vector>

namespace fast_grasp
{
/// The clusters of cloud[indices] (finite points) whose points are linked by chains of points
/// closer than `tolerance_m`, with min_points to max_points points; each cluster's indices
/// ascending, the clusters largest first (ties: lowest first index first). nullopt when the
/// points' bounding box would need more than `max_cells` grid cells (far-flung points): the
/// caller falls back to a k-d tree.
std::optional<std::vector<pcl::PointIndices>> gridEuclideanClusters(const CloudXYZ& cloud, const pcl::Indices& indices,
                                                                    double tolerance_m, int min_points, int max_points,
                                                                    std::size_t max_cells = 8000000);

}  // namespace fast_grasp
