// Thesis Ch6.2 steps 2 and 3: k-NN PCA normals oriented toward the camera, and the k-d-tree
// down-sampling of the normals. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>

#include <string>

namespace fast_grasp
{
struct NormalParams
{
  /// Neighbours per PCA plane fit (Eq. 6.5).
  int k_neighbours = 10;
  /// NormalEstimationOMP threads; 1 keeps the perception stage on one core.
  unsigned int threads = 1;
  /// Fewer points than this cannot give meaningful normals.
  int min_points = 10;
};

struct NormalResult
{
  bool ok = false;
  std::string reason;
  /// Same points as the input (minus those whose normal could not be fitted), unit normals
  /// with n . (viewpoint - p) >= 0, curvature filled; sensor_origin_ = viewpoint. Never null.
  CloudNormal::Ptr cloud;
};

/// k-NN normals (pcl::NormalEstimationOMP) of `object`, oriented toward `viewpoint` (base frame).
NormalResult estimateNormals(const CloudXYZ::ConstPtr& object, const Eigen::Vector3f& viewpoint,
                             const NormalParams& params);

/// Ch6 step 3: voxel-down-sample the points to `radius_m`, then for each down-sampled point
/// take the nearest original point (k-d tree, k = 1) with its dense normal. Returns original
/// points only (no averaged normals). radius_m <= 0 returns a copy. Never null.
CloudNormal::Ptr downsampleNormals(const CloudNormal& normals, double radius_m);

}  // namespace fast_grasp
