// Statistics the benchmarks print. Header-only; the benchmarks are single translation units.
#pragma once

#include <algorithm>
#include <cstddef>
#include <ctime>
#include <vector>

namespace fast_grasp
{
/// Median of `values` (mean of the two middle ones for an even count); 0 for none.
inline double median(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/// This thread's CPU time in milliseconds: the work "on one core", which other processes on a
/// shared machine do not inflate as they do wall time.
inline double threadCpuMs()
{
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

}  // namespace fast_grasp
