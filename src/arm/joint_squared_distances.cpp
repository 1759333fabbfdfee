#include "fast_grasp/arm/joint_nearest_neighbors.h"

#include <cmath>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define FAST_GRASP_X86_CLONES 1
#endif

namespace fast_grasp
{
// Two builds of one loop, chosen when the library loads (GCC's target_clones): with AVX2 the
// passes over the tree's joint columns take four states per instruction instead of SSE2's
// two (RRTConnect's nearest-neighbour scans were 15 % of the UR5 narrow passage benchmark).
// "avx2" does not enable FMA, so each element's sum is the same rounding sequence as the
// scalar distance (difference, square, add in joint order): the same nearest states.
#ifdef FAST_GRASP_X86_CLONES
__attribute__((target_clones("avx2", "default")))
#endif
void jointSquaredDistances(const double* const* columns, const double* query, const char* continuous,
                           std::size_t joints, std::size_t n, double* squared)
{
  constexpr double kTwoPi = 2.0 * M_PI;
  for (std::size_t j = 0; j < joints; ++j)
  {
    const double q = query[j];
    const double* column = columns[j];
    if (continuous[j])
    {
      for (std::size_t i = 0; i < n; ++i)
      {
        const double d = std::abs(column[i] - q);
        const double other = kTwoPi - d;
        const double m = other < d ? other : d;
        squared[i] = (j == 0 ? 0.0 : squared[i]) + m * m;
      }
    }
    else if (j == 0)
    {
      for (std::size_t i = 0; i < n; ++i)
      {
        const double d = column[i] - q;
        squared[i] = d * d;
      }
    }
    else
    {
      for (std::size_t i = 0; i < n; ++i)
      {
        const double d = column[i] - q;
        squared[i] += d * d;
      }
    }
  }
}

#ifdef FAST_GRASP_X86_CLONES
namespace
{
/// firstMinimumIndex with AVX: the minimum in four lanes (vminpd keeps the running minimum
/// when the new value is NaN, as the scalar `value < best` does), then the first index
/// holding it.
__attribute__((target("avx2"))) std::size_t firstMinimumIndexAvx2(const double* values, std::size_t n)
{
  __m256d best = _mm256_set1_pd(values[0]);
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4)
    best = _mm256_min_pd(_mm256_loadu_pd(values + i), best);
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, best);
  double minimum = lanes[0];
  for (int k = 1; k < 4; ++k)
    minimum = lanes[k] < minimum ? lanes[k] : minimum;
  for (; i < n; ++i)
    minimum = values[i] < minimum ? values[i] : minimum;
  const __m256d wanted = _mm256_set1_pd(minimum);
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4)
  {
    const int equal = _mm256_movemask_pd(_mm256_cmp_pd(_mm256_loadu_pd(values + k), wanted, _CMP_EQ_OQ));
    if (equal)
      return k + static_cast<std::size_t>(__builtin_ctz(static_cast<unsigned>(equal)));
  }
  for (; k < n; ++k)
    if (values[k] == minimum)
      return k;
  return 0;
}
}  // namespace
#endif

std::size_t firstMinimumIndex(const double* values, std::size_t n)
{
  if (n == 0 || std::isnan(values[0]))
    return 0;
#ifdef FAST_GRASP_X86_CLONES
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2)
    return firstMinimumIndexAvx2(values, n);
#endif
  std::size_t best = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (values[i] < values[best])
      best = i;
  return best;
}

}  // namespace fast_grasp
