// Wilson's score interval and the median of finite values; see statistics.h.
#include "rmpmarl/math/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rmpmarl::math {

Interval WilsonInterval(int successes, int trials, double z) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (trials <= 0) return {kNaN, kNaN, kNaN};
  const double n = trials, p = static_cast<double>(successes) / n, z2 = z * z;
  const double denominator = 1.0 + z2 / n;
  const double centre = (p + z2 / (2.0 * n)) / denominator;
  const double half = z * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denominator;
  return {p, std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

double FiniteMedian(std::vector<double> values) {
  std::erase_if(values, [](double v) { return !std::isfinite(v); });
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace rmpmarl::math
