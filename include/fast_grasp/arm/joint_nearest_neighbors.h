// Exact nearest-neighbour search over joint vectors for OMPL's tree planners (RRTConnect's two
// trees): a linear scan over the joints stored column by column, so that the distance to every
// tree state is a few vectorised passes instead of one virtual distance call per state.
// ROS-free; OMPL's NearestNeighbors interface.
#pragma once

#include <iostream>  // NearestNeighborsGNATNoThreadSafety.h uses std::cout without including it
#include <ompl/datastructures/NearestNeighbors.h>
#include <ompl/datastructures/NearestNeighborsGNATNoThreadSafety.h>
#include <ompl/util/Exception.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <numeric>
#include <utility>
#include <vector>

namespace fast_grasp
{
/// squared[i] = sum_j d_j(columns[j][i], query[j])^2 for i < n, the terms added in joint order
/// (d_j: the difference, the short way round for continuous[j]); src/arm/joint_squared_distances.cpp.
void jointSquaredDistances(const double* const* columns, const double* query, const char* continuous,
                           std::size_t joints, std::size_t n, double* squared);
/// The first index of the smallest value among values[0..n) (NaN never smaller; 0 if values[0]
/// is NaN or n is 0): Eigen's minCoeff(&index), with AVX when the CPU has it.
std::size_t firstMinimumIndex(const double* values, std::size_t n);

/// Nearest neighbours under the joint-space distance sqrt(sum_j d_j^2), d_j = |a_j - b_j|,
/// taken the short way round (min(d_j, 2 pi - d_j)) for continuous joints: the ArmStateSpace's
/// distance, computed in the same order, so the answers are the ones GNAT gives with it (ties
/// aside). Why not GNAT: on the LWR's RRTConnect shelf pick (trees of ~600 states) GNAT spent
/// 40 % of solve() in the distance calls through std::function and the state space's virtual
/// distance (docs/benchmarks/arms.md, "Speed work"). OMPL's NearestNeighborsLinear makes the
/// same calls one per state and was slower than GNAT. A scan grows with the tree and GNAT
/// does not (as fast at 16000 uniform 7-D states): from `gnat_from_size` states on, the
/// elements move into OMPL's GNAT with the distance function the planner set, so a long
/// search on a hard problem keeps GNAT's cost per query. Not thread-safe (like
/// GNATNoThreadSafety).
template <typename T>
class JointNearestNeighbors : public ompl::NearestNeighbors<T>
{
public:
  /// Writes an element's joint values to q (continuous.size() of them; RRTConnect: its
  /// Motion's state).
  using JointsOf = std::function<void(const T&, double* q)>;

  /// continuous[j] marks the joints whose difference wraps at 2 pi. From gnat_from_size
  /// elements on (once the planner has set the distance function), GNAT answers.
  JointNearestNeighbors(std::vector<bool> continuous, JointsOf joints_of, std::size_t gnat_from_size = 4096)
    : continuous_(continuous.begin(), continuous.end())
    , joints_of_(std::move(joints_of))
    , gnat_from_size_(gnat_from_size)
    , joints_(continuous_.size())
    , query_(continuous_.size(), 0.0)
  {
  }

  /// True once the elements have moved into GNAT.
  bool usesGnat() const { return gnat_ != nullptr; }

  bool reportsSortedResults() const override { return true; }
  void clear() override
  {
    gnat_.reset();
    clearScan();
  }
  void add(const T& data) override
  {
    if (gnat_)
    {
      gnat_->add(data);
      return;
    }
    if (elements_.size() + 1 >= gnat_from_size_ && this->distFun_)
    {
      gnat_ = std::make_unique<ompl::NearestNeighborsGNATNoThreadSafety<T>>();
      gnat_->setDistanceFunction(this->distFun_);
      elements_.push_back(data);
      gnat_->add(elements_);
      clearScan();
      return;
    }
    joints_of_(data, query_.data());
    for (std::size_t j = 0; j < joints_.size(); ++j)
      joints_[j].push_back(query_[j]);
    elements_.push_back(data);
  }
  bool remove(const T& data) override
  {
    if (gnat_)
      return gnat_->remove(data);
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
    if (gnat_)
      return gnat_->nearest(data);
    if (elements_.empty())
      throw ompl::Exception("JointNearestNeighbors: no elements");
    const Eigen::Map<const Eigen::ArrayXd> squared = squaredDistances(data);
    return elements_[firstMinimumIndex(squared.data(), static_cast<std::size_t>(squared.size()))];  // the first of equals
  }
  void nearestK(const T& data, std::size_t k, std::vector<T>& nbh) const override
  {
    if (gnat_)
      return gnat_->nearestK(data, k, nbh);
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
    if (gnat_)
      return gnat_->nearestR(data, radius, nbh);
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
  std::size_t size() const override { return gnat_ ? gnat_->size() : elements_.size(); }
  void list(std::vector<T>& data) const override
  {
    if (gnat_)
      gnat_->list(data);
    else
      data = elements_;
  }

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
  void clearScan()
  {
    elements_.clear();
    for (std::vector<double>& column : joints_)
      column.clear();
  }

  /// Squared distance from `data` to every element, joint by joint in distance()'s order (no
  /// allocation once the scratch has grown to the tree's size).
  Eigen::Map<const Eigen::ArrayXd> squaredDistances(const T& data) const
  {
    joints_of_(data, query_.data());
    const Eigen::Index n = static_cast<Eigen::Index>(elements_.size());
    squared_.resize(elements_.size());
    if (joints_.empty())
      std::fill(squared_.begin(), squared_.end(), 0.0);
    column_data_.resize(joints_.size());
    for (std::size_t j = 0; j < joints_.size(); ++j)
      column_data_[j] = joints_[j].data();
    jointSquaredDistances(column_data_.data(), query_.data(), continuous_.data(), joints_.size(),
                          elements_.size(), squared_.data());
    return Eigen::Map<const Eigen::ArrayXd>(squared_.data(), n);
  }

  std::vector<char> continuous_;  // per joint: wraps at 2 pi (bytes: jointSquaredDistances reads them)
  JointsOf joints_of_;
  std::size_t gnat_from_size_;
  std::unique_ptr<ompl::NearestNeighborsGNATNoThreadSafety<T>> gnat_;  // null while scanning
  std::vector<std::vector<double>> joints_;  // joints_[j][i]: joint j of element i
  std::vector<T> elements_;
  mutable std::vector<double> query_;    // scratch: the query's joints
  mutable std::vector<double> squared_;  // scratch: squared distances of the last query
  mutable std::vector<const double*> column_data_;  // scratch: joints_[j].data()
};

}  // namespace fast_grasp
