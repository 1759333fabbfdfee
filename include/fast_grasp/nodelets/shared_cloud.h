// Zero-copy hand-over between roscpp (boost::shared_ptr) and PCL 1.13 / the core
// (std::shared_ptr): each pointer keeps the other alive, no point is copied.
#pragma once

#include <boost/shared_ptr.hpp>

#include <memory>

namespace fast_grasp
{
/// A boost pointer (for publishing) sharing ownership with a core std pointer.
template <typename T>
boost::shared_ptr<T> toBoost(const std::shared_ptr<T>& p)
{
  return boost::shared_ptr<T>(p.get(), [p](T*) {});
}

/// A std pointer (for the core) sharing ownership with a received boost pointer.
template <typename T>
std::shared_ptr<T> toStd(const boost::shared_ptr<T>& p)
{
  return std::shared_ptr<T>(p.get(), [p](T*) {});
}

}  // namespace fast_grasp
