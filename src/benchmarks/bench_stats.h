// Statistics the benchmarks print. Header-only; the benchmarks are single translation units.
#pragma once

#include <algorithm>
#include <cstddef>
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

}  // namespace fast_grasp
