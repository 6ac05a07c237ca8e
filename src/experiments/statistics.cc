#include "rmpmarl/experiments/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace rmpmarl::experiments {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

Interval WilsonInterval(int successes, int trials, double z) {
  if (trials <= 0) return {kNaN, kNaN, kNaN};
  const double n = trials, p = static_cast<double>(successes) / n, z2 = z * z;
  const double denominator = 1.0 + z2 / n;
  const double centre = (p + z2 / (2.0 * n)) / denominator;
  const double half = z * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denominator;
  return {p, std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

Interval BootstrapMeanInterval(const std::vector<double>& values, std::uint64_t seed, int resamples,
                               double confidence) {
  std::vector<double> x;
  x.reserve(values.size());
  for (double v : values) {
    if (std::isfinite(v)) x.push_back(v);
  }
  if (x.empty()) return {kNaN, kNaN, kNaN};
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  if (x.size() == 1 || resamples < 1) return {mean, mean, mean};
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, x.size() - 1);
  std::vector<double> means(resamples);
  for (double& m : means) {
    double sum = 0.0;
    for (size_t k = 0; k < x.size(); ++k) sum += x[pick(rng)];
    m = sum / static_cast<double>(x.size());
  }
  std::sort(means.begin(), means.end());
  const double alpha = 0.5 * (1.0 - confidence);
  const auto at = [&](double q) {
    const double pos = q * (resamples - 1);
    const size_t lo = static_cast<size_t>(std::floor(pos));
    const size_t hi = std::min(lo + 1, means.size() - 1);
    return means[lo] + (pos - lo) * (means[hi] - means[lo]);
  };
  return {mean, at(alpha), at(1.0 - alpha)};
}

}  // namespace rmpmarl::experiments
