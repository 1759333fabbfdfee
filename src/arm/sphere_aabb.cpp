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
/// it does ((x^2 + y^2) + z^2 <= r^2, ordered: false for NaN).
__attribute__((target("avx2"))) void masksAvx2(const double* lanes, std::size_t groups, const Eigen::Vector3d* centres,
                                                const double* radius2, std::size_t spheres, std::uint64_t* masks)
{
  const __m256d zero = _mm256_setzero_pd();
  for (std::size_t s = 0; s < spheres; ++s)
  {
    if (!(radius2[s] >= 0.0))
    {
      masks[s] = 0;
      continue;
    }
    const __m256d r2 = _mm256_set1_pd(radius2[s]);
    const __m256d c[3] = { _mm256_set1_pd(centres[s].x()), _mm256_set1_pd(centres[s].y()),
                           _mm256_set1_pd(centres[s].z()) };
    std::uint64_t mask = 0;
    for (std::size_t g = 0; g < groups; ++g)
    {
      const double* p = lanes + 24 * g;
      __m256d gap[3];
      for (int axis = 0; axis < 3; ++axis)
      {
        const __m256d below = _mm256_sub_pd(_mm256_loadu_pd(p + 4 * axis), c[axis]);
        const __m256d above = _mm256_sub_pd(c[axis], _mm256_loadu_pd(p + 4 * (3 + axis)));
        gap[axis] = _mm256_max_pd(zero, _mm256_max_pd(below, above));
      }
      const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(gap[0], gap[0]), _mm256_mul_pd(gap[1], gap[1])),
                                       _mm256_mul_pd(gap[2], gap[2]));
      mask |= static_cast<std::uint64_t>(_mm256_movemask_pd(_mm256_cmp_pd(d2, r2, _CMP_LE_OQ))) << (4 * g);
    }
    masks[s] = mask;
  }
}

/// The same with SSE2, two boxes per instruction.
void masksSse2(const double* lanes, std::size_t groups, const Eigen::Vector3d* centres, const double* radius2,
               std::size_t spheres, std::uint64_t* masks)
{
  const __m128d zero = _mm_setzero_pd();
  for (std::size_t s = 0; s < spheres; ++s)
  {
    if (!(radius2[s] >= 0.0))
    {
      masks[s] = 0;
      continue;
    }
    const __m128d r2 = _mm_set1_pd(radius2[s]);
    const __m128d c[3] = { _mm_set1_pd(centres[s].x()), _mm_set1_pd(centres[s].y()), _mm_set1_pd(centres[s].z()) };
    std::uint64_t mask = 0;
    for (std::size_t g = 0; g < groups; ++g)
      for (std::size_t half = 0; half < 2; ++half)
      {
        const double* p = lanes + 24 * g + 2 * half;
        __m128d gap[3];
        for (int axis = 0; axis < 3; ++axis)
        {
          const __m128d below = _mm_sub_pd(_mm_loadu_pd(p + 4 * axis), c[axis]);
          const __m128d above = _mm_sub_pd(c[axis], _mm_loadu_pd(p + 4 * (3 + axis)));
          gap[axis] = _mm_max_pd(zero, _mm_max_pd(below, above));
        }
        const __m128d d2 =
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(gap[0], gap[0]), _mm_mul_pd(gap[1], gap[1])), _mm_mul_pd(gap[2], gap[2]));
        mask |= static_cast<std::uint64_t>(_mm_movemask_pd(_mm_cmple_pd(d2, r2))) << (4 * g + 2 * half);
      }
    masks[s] = mask;
  }
}
#endif
}  // namespace

void sphereAabbMasks(const AabbLanes& boxes, std::size_t first, std::size_t count, const Eigen::Vector3d* centres,
                     const double* radius2, std::size_t spheres, std::uint64_t* masks)
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
  if (avx2)
    masksAvx2(lanes, groups, centres, radius2, spheres, masks);
  else
    masksSse2(lanes, groups, centres, radius2, spheres, masks);
  for (std::size_t s = 0; s < spheres; ++s)
    masks[s] &= all;
#else
  (void)all;
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
