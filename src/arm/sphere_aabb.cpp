#include "fast_grasp/arm/sphere_aabb.h"

#include <cstring>
#include <limits>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define FAST_GRASP_X86 1
#endif

namespace fast_grasp
{
void AabbLanes::assign(const std::vector<Eigen::Vector3d>& lo, const std::vector<Eigen::Vector3d>& hi)
{
  boxes_ = std::min(lo.size(), hi.size());
  const std::size_t groups = (boxes_ + kLanes - 1) / kLanes;
  // Padding lanes: a box at +1e300 on every axis; its gap squares to +inf, which compares
  // greater than any radius.
  lanes_.assign(6 * kLanes * groups, 1e300);
  for (std::size_t k = 0; k < boxes_; ++k)
  {
    double* g = lanes_.data() + 6 * kLanes * (k / kLanes);
    for (int axis = 0; axis < 3; ++axis)
    {
      g[axis * kLanes + k % kLanes] = lo[k][axis];
      g[(3 + axis) * kLanes + k % kLanes] = hi[k][axis];
    }
  }
}

namespace
{
#ifdef FAST_GRASP_X86
/// maxpd / cmplepd on four boxes at a time: vmaxpd returns its second operand unless the
/// first is greater, as _mm_max_pd in sphereMayTouchAabb, and each lane sums and compares as
/// it does ((x^2 + y^2) + z^2 <= r^2, ordered: false for NaN, and for a negative r^2 as the
/// squared gap is never negative). A group's boxes stay in registers for all spheres.
__attribute__((target("avx2"))) void masksAvx2(const double* lanes, std::size_t groups, const Eigen::Vector3d* centres,
                                                const double* radius2, std::size_t spheres, std::uint64_t* masks)
{
  const __m256d zero = _mm256_setzero_pd();
  std::fill(masks, masks + spheres, 0);
  for (std::size_t g = 0; g < groups; ++g)
  {
    const double* p = lanes + 24 * g;
    __m256d lo[3], hi[3];
    for (int axis = 0; axis < 3; ++axis)
    {
      lo[axis] = _mm256_loadu_pd(p + 4 * axis);
      hi[axis] = _mm256_loadu_pd(p + 4 * (3 + axis));
    }
    for (std::size_t s = 0; s < spheres; ++s)
    {
      __m256d gap[3];
      for (int axis = 0; axis < 3; ++axis)
      {
        const __m256d c = _mm256_set1_pd(centres[s][axis]);
        gap[axis] = _mm256_max_pd(zero, _mm256_max_pd(_mm256_sub_pd(lo[axis], c), _mm256_sub_pd(c, hi[axis])));
      }
      const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(gap[0], gap[0]), _mm256_mul_pd(gap[1], gap[1])),
                                       _mm256_mul_pd(gap[2], gap[2]));
      masks[s] |= static_cast<std::uint64_t>(_mm256_movemask_pd(_mm256_cmp_pd(d2, _mm256_set1_pd(radius2[s]), _CMP_LE_OQ)))
                  << (4 * g);
    }
  }
}

/// The same with SSE2, two boxes per instruction.
void masksSse2(const double* lanes, std::size_t groups, const Eigen::Vector3d* centres, const double* radius2,
               std::size_t spheres, std::uint64_t* masks)
{
  const __m128d zero = _mm_setzero_pd();
  std::fill(masks, masks + spheres, 0);
  for (std::size_t pair = 0; pair < 2 * groups; ++pair)
  {
    const double* p = lanes + 24 * (pair / 2) + 2 * (pair % 2);
    __m128d lo[3], hi[3];
    for (int axis = 0; axis < 3; ++axis)
    {
      lo[axis] = _mm_loadu_pd(p + 4 * axis);
      hi[axis] = _mm_loadu_pd(p + 4 * (3 + axis));
    }
    for (std::size_t s = 0; s < spheres; ++s)
    {
      __m128d gap[3];
      for (int axis = 0; axis < 3; ++axis)
      {
        const __m128d c = _mm_set1_pd(centres[s][axis]);
        gap[axis] = _mm_max_pd(zero, _mm_max_pd(_mm_sub_pd(lo[axis], c), _mm_sub_pd(c, hi[axis])));
      }
      const __m128d d2 =
          _mm_add_pd(_mm_add_pd(_mm_mul_pd(gap[0], gap[0]), _mm_mul_pd(gap[1], gap[1])), _mm_mul_pd(gap[2], gap[2]));
      masks[s] |= static_cast<std::uint64_t>(_mm_movemask_pd(_mm_cmple_pd(d2, _mm_set1_pd(radius2[s])))) << (2 * pair);
    }
  }
}
#endif
}  // namespace

void sphereAabbMasks(const AabbLanes& boxes, std::size_t first, std::size_t count, const Eigen::Vector3d* centres,
                     const double* radius2, std::size_t spheres, std::uint64_t* masks, bool allow_avx2)
{
  static_assert(AabbLanes::kLanes == 4, "the kernels work on groups of four boxes");
  count = std::min<std::size_t>({ count, 64, first < boxes.size() ? boxes.size() - first : 0 });
  const std::uint64_t all = count == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << count) - 1;
  if (count == 0)
  {
    std::fill(masks, masks + spheres, 0);
    return;
  }
#ifdef FAST_GRASP_X86
  static const bool avx2 = __builtin_cpu_supports("avx2");
  const double* lanes = boxes.group(first / AabbLanes::kLanes);
  const std::size_t groups = (count + 3) / 4;
  if (avx2 && allow_avx2)
    masksAvx2(lanes, groups, centres, radius2, spheres, masks);
  else
    masksSse2(lanes, groups, centres, radius2, spheres, masks);
  for (std::size_t s = 0; s < spheres; ++s)
    masks[s] &= all;
#else
  (void)all;
  (void)allow_avx2;
  for (std::size_t s = 0; s < spheres; ++s)
  {
    masks[s] = 0;
    if (radius2[s] >= 0.0)
      for (std::size_t k = 0; k < count; ++k)
        if (sphereMayTouchAabb(centres[s], radius2[s], boxes.lo(first + k), boxes.hi(first + k)))
          masks[s] |= std::uint64_t(1) << k;
  }
#endif
}

}  // namespace fast_grasp
