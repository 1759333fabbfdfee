// Small geometric building blocks shared by the grasp planners. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace fast_grasp
{
/// Centroid and principal axes of a point set (Eqs. 3.1-3.2): axes.col(0) is the
/// eigenvector of the largest eigenvalue, eigenvalues are sorted descending.
struct PrincipalFrame
{
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();  // right-handed
  Eigen::Vector3f eigenvalues = Eigen::Vector3f::Zero();
  std::size_t point_count = 0;
};

/// PCA of the finite points of `cloud` (or of `indices` into it when not empty).
/// Returns point_count == 0 when there is no finite point.
template <typename PointT>
PrincipalFrame computePrincipalFrame(const pcl::PointCloud<PointT>& cloud,
                                     const std::vector<int>& indices = {});

/// The median of `values` (the upper one of an even count), found in place: their order changes.
/// `values` must not be empty.
float medianInPlace(std::vector<float>& values);

/// Least-squares line y = k x + b through 2-D points (Eq. 3.5).
struct LineFit
{
  double k = 0.0;
  double b = 0.0;
  bool vertical = false;  // all x equal (k infinite): angle is pi/2
  /// Angle of the line to the x axis, in (-pi/2, pi/2]; atan(k).
  double angleRad() const;
};
LineFit fitLine(const std::vector<Eigen::Vector2d>& points);

/// Total least-squares (orthogonal) line direction through 2-D points, robust for any slope.
Eigen::Vector2d fitLineDirection(const std::vector<Eigen::Vector2d>& points);

/// Morphological closing of a row-major `cols` x `rows` occupancy grid (non-zero = occupied):
/// `iterations` 3x3 dilations, then as many erosions, as separable passes (O(cells)). It bridges
/// holes of up to 2 x iterations cells between scan points, so they are not read as contour.
/// The caller pads the grid with at least iterations + 1 empty cells on every side (the outer
/// ring is kept empty and the dilation must not reach it).
void closeBinaryGrid(std::vector<std::uint8_t>& grid, int cols, int rows, int iterations);

}  // namespace fast_grasp
