// Exact nearest-neighbour search over joint vectors for OMPL's tree planners (RRTConnect's two
// trees): a linear scan over the joints stored column by column, so that the distance to every
// tree state is a few vectorised passes instead of one virtual distance call per state.
// ROS-free; OMPL's NearestNeighbors interface.
#pragma once

#include <ompl/datastructures/NearestNeighbors.h>
#include <ompl/util/Exception.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <utility>
#include <vector>

namespace fast_grasp
{
/// Nearest neighbours under the joint-space distance sqrt(sum_j d_j^2), d_j = |a_j - b_j|,
/// taken the short way round (min(d_j, 2 pi - d_j)) for continuous joints: the ArmStateSpace's
/// distance, computed in the same order, so the answers are the ones GNAT gives with it (ties
/// aside). Why not GNAT: on the LWR's RRTConnect shelf pick (trees of ~600 states) GNAT spent
/// 40 % of solve() in the distance calls through std::function and the state space's virtual
/// distance (docs/benchmarks/arms.md, "Speed work"). OMPL's NearestNeighborsLinear makes the
/// same calls one per state and was slower than GNAT. Not thread-safe (like GNATNoThreadSafety).
template <typename T>
class JointNearestNeighbors : public ompl::NearestNeighbors<T>
{
public:
  /// Writes an element's joint values to q (continuous.size() of them; RRTConnect: its
  /// Motion's state).
  using JointsOf = std::function<void(const T&, double* q)>;

  /// continuous[j] marks the joints whose difference wraps at 2 pi.
  JointNearestNeighbors(std::vector<bool> continuous, JointsOf joints_of)
    : continuous_(std::move(continuous))
    , joints_of_(std::move(joints_of))
    , joints_(continuous_.size())
    , query_(continuous_.size(), 0.0)
  {
  }

  bool reportsSortedResults() const override { return true; }
  void clear() override
  {
    elements_.clear();
    for (std::vector<double>& column : joints_)
      column.clear();
  }
  void add(const T& data) override
  {
    joints_of_(data, query_.data());
    for (std::size_t j = 0; j < joints_.size(); ++j)
      joints_[j].push_back(query_[j]);
    elements_.push_back(data);
  }
  bool remove(const T& data) override
  {
    const auto it = std::find(elements_.begin(), elements_.end(), data);
    if (it == elements_.end())
      return false;
    const std::size_t i = static_cast<std::size_t>(it - elements_.begin());
    elements_.erase(it);
    for (std::vector<double>& column : joints_)
      column.erase(column.begin() + static_cast<std::ptrdiff_t>(i));
    return true;
  }
  T nearest(const T& data) const override
  {
    if (elements_.empty())
      throw ompl::Exception("JointNearestNeighbors: no elements");
    Eigen::Index best = 0;
    squaredDistances(data).minCoeff(&best);  // the first of equals
    return elements_[static_cast<std::size_t>(best)];
  }
  void nearestK(const T& data, std::size_t k, std::vector<T>& nbh) const override
  {
    nbh.clear();
    if (k == 0 || elements_.empty())
      return;
    const Eigen::Map<const Eigen::ArrayXd> d2 = squaredDistances(data);
    std::vector<std::size_t> order(elements_.size());
    std::iota(order.begin(), order.end(), std::size_t(0));
    const std::size_t count = std::min(k, order.size());
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(count), order.end(),
                      [&d2](std::size_t a, std::size_t b) {
                        return d2[static_cast<Eigen::Index>(a)] < d2[static_cast<Eigen::Index>(b)];
                      });
    for (std::size_t i = 0; i < count; ++i)
      nbh.push_back(elements_[order[i]]);
  }
  void nearestR(const T& data, double radius, std::vector<T>& nbh) const override
  {
    nbh.clear();
    if (elements_.empty())
      return;
    const Eigen::Map<const Eigen::ArrayXd> d2 = squaredDistances(data);
    std::vector<std::size_t> within;
    for (std::size_t i = 0; i < elements_.size(); ++i)
      if (std::sqrt(d2[static_cast<Eigen::Index>(i)]) <= radius)
        within.push_back(i);
    std::sort(within.begin(), within.end(), [&d2](std::size_t a, std::size_t b) {
      return d2[static_cast<Eigen::Index>(a)] < d2[static_cast<Eigen::Index>(b)];
    });
    for (const std::size_t i : within)
      nbh.push_back(elements_[i]);
  }
  std::size_t size() const override { return elements_.size(); }
  void list(std::vector<T>& data) const override { data = elements_; }

  /// The distance this structure orders by, between two joint vectors (for tests).
  double distance(const double* a, const double* b) const
  {
    double sum = 0.0;
    for (std::size_t j = 0; j < continuous_.size(); ++j)
    {
      double d = std::abs(a[j] - b[j]);
      if (continuous_[j])
        d = std::min(d, 2.0 * M_PI - d);
      sum += d * d;
    }
    return std::sqrt(sum);
  }

private:
  /// Squared distance from `data` to every element, joint by joint in distance()'s order (no
  /// allocation once the scratch has grown to the tree's size).
  Eigen::Map<const Eigen::ArrayXd> squaredDistances(const T& data) const
  {
    joints_of_(data, query_.data());
    const Eigen::Index n = static_cast<Eigen::Index>(elements_.size());
    squared_.resize(elements_.size());
    Eigen::Map<Eigen::ArrayXd> squared(squared_.data(), n);
    squared.setZero();
    for (std::size_t j = 0; j < joints_.size(); ++j)
    {
      const double q = query_[j];
      const Eigen::Map<const Eigen::ArrayXd> column(joints_[j].data(), n);
      if (continuous_[j])
        squared += (column - q).abs().min(2.0 * M_PI - (column - q).abs()).square();
      else
        squared += (column - q).square();
    }
    return Eigen::Map<const Eigen::ArrayXd>(squared_.data(), n);
  }

  std::vector<bool> continuous_;
  JointsOf joints_of_;
  std::vector<std::vector<double>> joints_;  // joints_[j][i]: joint j of element i
  std::vector<T> elements_;
  mutable std::vector<double> query_;    // scratch: the query's joints
  mutable std::vector<double> squared_;  // scratch: squared distances of the last query
};

}  // namespace fast_grasp
