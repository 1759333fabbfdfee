#include "fast_grasp/grasping/grasp_geometry.h"

#include <pcl/common/centroid.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace fast_grasp
{
template <typename PointT>
PrincipalFrame computePrincipalFrame(const pcl::PointCloud<PointT>& cloud, const std::vector<int>& indices)
{
  PrincipalFrame frame;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  std::size_t n = 0;
  auto accumulate = [&](const PointT& p) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return;
    const Eigen::Vector3d v(p.x, p.y, p.z);
    sum += v;
    outer += v * v.transpose();
    ++n;
  };
  if (indices.empty())
    for (const auto& p : cloud.points)
      accumulate(p);
  else
    for (int i : indices)
      accumulate(cloud.points[static_cast<std::size_t>(i)]);
  frame.point_count = n;
  if (n == 0)
    return frame;
  const Eigen::Vector3d mean = sum / static_cast<double>(n);
  const Eigen::Matrix3d covariance = outer / static_cast<double>(n) - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  // Eigen sorts ascending; the thesis's lambda_1 > lambda_2 > lambda_3 order is descending.
  Eigen::Matrix3d axes;
  axes.col(0) = solver.eigenvectors().col(2);
  axes.col(1) = solver.eigenvectors().col(1);
  axes.col(2) = axes.col(0).cross(axes.col(1));
  frame.centroid = mean.cast<float>();
  frame.axes = axes.cast<float>();
  frame.eigenvalues = Eigen::Vector3d(solver.eigenvalues()(2), solver.eigenvalues()(1), solver.eigenvalues()(0))
                          .cwiseMax(0.0)
                          .cast<float>();
  return frame;
}

float medianInPlace(std::vector<float>& values)
{
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

double LineFit::angleRad() const
{
  return vertical ? M_PI / 2.0 : std::atan(k);
}

LineFit fitLine(const std::vector<Eigen::Vector2d>& points)
{
  LineFit fit;
  const double n = static_cast<double>(points.size());
  if (points.empty())
    return fit;
  double sx = 0, sy = 0, sxy = 0, sxx = 0;
  for (const auto& p : points)
  {
    sx += p.x();
    sy += p.y();
    sxy += p.x() * p.y();
    sxx += p.x() * p.x();
  }
  const double denominator = sxx - sx * sx / n;
  if (std::abs(denominator) < 1e-12 * std::max(1.0, sxx))
  {
    fit.vertical = true;
    fit.k = std::numeric_limits<double>::infinity();
    fit.b = std::numeric_limits<double>::quiet_NaN();
    return fit;
  }
  fit.k = (sxy - sx * sy / n) / denominator;  // Eq. 3.5
  fit.b = sy / n - fit.k * sx / n;
  return fit;
}

Eigen::Vector2d fitLineDirection(const std::vector<Eigen::Vector2d>& points)
{
  if (points.size() < 2)
    return Eigen::Vector2d::UnitX();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points)
    mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  for (const auto& p : points)
    covariance += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(covariance);
  return solver.eigenvectors().col(1);
}

template PrincipalFrame computePrincipalFrame(const pcl::PointCloud<pcl::PointXYZ>&, const std::vector<int>&);
template PrincipalFrame computePrincipalFrame(const pcl::PointCloud<pcl::PointNormal>&, const std::vector<int>&);

void closeBinaryGrid(std::vector<std::uint8_t>& grid, int cols, int rows, int iterations)
{
  if (cols < 3 || rows < 3 || iterations <= 0 || grid.size() != static_cast<std::size_t>(cols) * rows)
    return;
  auto at = [cols](int c, int r) { return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + c; };
  std::vector<std::uint8_t> rows_pass(grid.size(), 0);
  auto pass = [&](bool dilate) {
    for (int r = 0; r < rows; ++r)
      for (int c = 1; c < cols - 1; ++c)
      {
        const bool a = grid[at(c - 1, r)], b = grid[at(c, r)], d = grid[at(c + 1, r)];
        rows_pass[at(c, r)] = static_cast<std::uint8_t>(dilate ? (a || b || d) : (a && b && d));
      }
    for (int r = 1; r < rows - 1; ++r)
      for (int c = 0; c < cols; ++c)
      {
        const bool a = rows_pass[at(c, r - 1)], b = rows_pass[at(c, r)], d = rows_pass[at(c, r + 1)];
        grid[at(c, r)] = static_cast<std::uint8_t>(dilate ? (a || b || d) : (a && b && d));
      }
    for (int c = 0; c < cols; ++c)
      grid[at(c, 0)] = grid[at(c, rows - 1)] = 0;
    for (int r = 0; r < rows; ++r)
      grid[at(0, r)] = grid[at(cols - 1, r)] = 0;
  };
  for (int k = 0; k < iterations; ++k)
    pass(true);
  for (int k = 0; k < iterations; ++k)
    pass(false);
}

}  // namespace fast_grasp
