// Can a sphere reach an axis-aligned box? One box, or a sphere against many boxes at once.
// The broad phase of RobotCollision against the scene's boxes. ROS-free.
#pragma once

#include <Eigen/Core>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace fast_grasp
{
/// Can a sphere (centre, radius squared) reach the axis-aligned box [lo, hi]? The exact
/// squared distance from the centre to the box, branch-free.
inline bool sphereMayTouchAabb(const Eigen::Vector3d& centre, double radius2, const Eigen::Vector3d& lo,
                               const Eigen::Vector3d& hi)
{
#ifdef __SSE2__
  // maxpd: GCC compiles std::max on doubles to compare-and-branch (its result differs from
  // maxsd's on +-0), six unpredictable branches per test.
  const __m128d zero = _mm_setzero_pd();
  const __m128d c_xy = _mm_loadu_pd(centre.data()), c_z = _mm_load_sd(centre.data() + 2);
  const __m128d g_xy = _mm_max_pd(
      zero, _mm_max_pd(_mm_sub_pd(_mm_loadu_pd(lo.data()), c_xy), _mm_sub_pd(c_xy, _mm_loadu_pd(hi.data()))));
  const __m128d g_z = _mm_max_sd(
      zero, _mm_max_sd(_mm_sub_sd(_mm_load_sd(lo.data() + 2), c_z), _mm_sub_sd(c_z, _mm_load_sd(hi.data() + 2))));
  const __m128d sq_xy = _mm_mul_pd(g_xy, g_xy);
  const __m128d sum = _mm_add_sd(_mm_add_sd(sq_xy, _mm_unpackhi_pd(sq_xy, sq_xy)), _mm_mul_sd(g_z, g_z));
  return _mm_cvtsd_f64(sum) <= radius2;
#else
  // maxpd's rule: the second operand unless the first is greater.
  auto maxpd = [](double a, double b) { return a > b ? a : b; };
  const double gx = maxpd(0.0, maxpd(lo.x() - centre.x(), centre.x() - hi.x()));
  const double gy = maxpd(0.0, maxpd(lo.y() - centre.y(), centre.y() - hi.y()));
  const double gz = maxpd(0.0, maxpd(lo.z() - centre.z(), centre.z() - hi.z()));
  return (gx * gx + gy * gy) + gz * gz <= radius2;
#endif
}

/// Axis-aligned boxes laid out four at a time for sphereAabbMask: per group of four boxes
/// their lo x, y, z and hi x, y, z, four lanes each. Lanes after the last box hold a box no
/// sphere reaches.
class AabbLanes
{
public:
  static constexpr std::size_t kLanes = 4;
  void assign(const std::vector<Eigen::Vector3d>& lo, const std::vector<Eigen::Vector3d>& hi);
  std::size_t size() const { return boxes_; }
  Eigen::Vector3d lo(std::size_t k) const { return corner(k, 0); }
  Eigen::Vector3d hi(std::size_t k) const { return corner(k, 3); }
  /// lanes of group g (kLanes boxes from box kLanes * g on).
  const double* group(std::size_t g) const { return lanes_.data() + 6 * kLanes * g; }

private:
  Eigen::Vector3d corner(std::size_t k, int row) const
  {
    const double* g = group(k / kLanes);
    return Eigen::Vector3d(g[row * kLanes + k % kLanes], g[(row + 1) * kLanes + k % kLanes],
                           g[(row + 2) * kLanes + k % kLanes]);
  }
  std::vector<double> lanes_;
  std::size_t boxes_ = 0;
};

/// For each sphere s (centres[s], radius2[s]; a negative radius2 is no sphere: mask 0),
/// masks[s] has bit k - first set when sphereMayTouchAabb(centres[s], radius2[s], lo[k],
/// hi[k]), for the boxes k = first .. first + count - 1 of `boxes` (first a multiple of
/// AabbLanes::kLanes, count <= 64). The same arithmetic on four boxes per instruction (AVX2
/// when the CPU has it, else two with SSE2): the same verdicts. Why: a UR5 check tested each
/// of 5 bodies against each of the narrow passage's 5 boxes one by one, ~1 300 of its ~7 500
/// instructions. allow_avx2 = false takes the SSE2 kernel on any CPU (for its test).
void sphereAabbMasks(const AabbLanes& boxes, std::size_t first, std::size_t count, const Eigen::Vector3d* centres,
                     const double* radius2, std::size_t spheres, std::uint64_t* masks, bool allow_avx2 = true);

}  // namespace fast_grasp
