// Where points stand on the table: occupied cells of their projections onto the table plane.
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <unordered_set>

namespace fast_grasp
{
/// Occupied square cells (cell_m wide) of points projected along the table normal. A hash set
/// rather than a 2-D k-d tree: one lookup per query point. Used for a cluster's footprint (is a
/// part stacked over the target?) and for where the camera saw the table (can a piece stand?).
class TableFootprint
{
public:
  /// `plane`: a, b, c, d of the table (only the normal's direction is used).
  TableFootprint(const Eigen::Vector4f& plane, double cell_m) : cell_m_(static_cast<float>(cell_m))
  {
    const Eigen::Vector3f normal = plane.head<3>().normalized();
    u_ = normal.unitOrthogonal();
    v_ = normal.cross(u_);
  }
  /// Marks the cell of `p`, and the cells around it when `dilate` (a one-cell margin for noise).
  void add(const Eigen::Vector3f& p, bool dilate = false)
  {
    const Cell c = cellOf(p);
    const int reach = dilate ? 1 : 0;
    for (int di = -reach; di <= reach; ++di)
      for (int dj = -reach; dj <= reach; ++dj)
        cells_.insert(key(c.i + di, c.j + dj));
  }
  bool covers(const Eigen::Vector3f& p) const
  {
    const Cell c = cellOf(p);
    return cells_.count(key(c.i, c.j)) > 0;
  }

private:
  struct Cell
  {
    std::int64_t i, j;
  };
  Cell cellOf(const Eigen::Vector3f& p) const
  {
    return { static_cast<std::int64_t>(std::floor(u_.dot(p) / cell_m_)),
             static_cast<std::int64_t>(std::floor(v_.dot(p) / cell_m_)) };
  }
  // Shifted as unsigned: a left shift of a negative index (cells left of or behind the origin) is
  // undefined behaviour (UBSan on the cracker_box bag); the bits are the same.
  static std::uint64_t key(std::int64_t i, std::int64_t j)
  {
    return (static_cast<std::uint64_t>(i) << 32) ^ (static_cast<std::uint64_t>(j) & 0xffffffffu);
  }

  float cell_m_;
  Eigen::Vector3f u_, v_;
  std::unordered_set<std::uint64_t> cells_;
};

}  // namespace fast_grasp
