// Disjoint sets over 0..n-1 (union-find with path halving), for the segmentation's joins: the
// crease split's pieces (concave_split.cpp) and the grid's cells (grid_clusters.cpp). ROS-free.
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace fast_grasp
{
class UnionFind
{
public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), std::size_t{ 0 }); }
  /// The representative of i's set.
  std::size_t find(std::size_t i)
  {
    while (parent_[i] != i)
      i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  /// Merges a's set into b's (b's representative stays).
  void join(std::size_t a, std::size_t b) { parent_[find(a)] = find(b); }
  std::size_t size() const { return parent_.size(); }

private:
  std::vector<std::size_t> parent_;
};

}  // namespace fast_grasp
