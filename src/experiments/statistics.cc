#include "rmpmarl/experiments/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace rmpmarl::experiments {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
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

Interval HierarchicalBootstrapMeanInterval(const std::vector<std::vector<double>>& groups, std::uint64_t seed,
                                           int resamples, double confidence) {
  std::vector<std::vector<double>> g;
  for (const std::vector<double>& group : groups) {
    std::vector<double> finite;
    for (double v : group) {
      if (std::isfinite(v)) finite.push_back(v);
    }
    if (!finite.empty()) g.push_back(std::move(finite));
  }
  if (g.empty()) return {kNaN, kNaN, kNaN};
  if (g.size() == 1) return BootstrapMeanInterval(g[0], seed, resamples, confidence);
  double sum = 0.0;
  size_t count = 0;
  for (const auto& group : g) {
    for (double v : group) sum += v;
    count += group.size();
  }
  const double mean = sum / static_cast<double>(count);
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick_group(0, g.size() - 1);
  std::vector<double> means(std::max(resamples, 1));
  for (double& m : means) {
    double s = 0.0;
    size_t n = 0;
    for (size_t k = 0; k < g.size(); ++k) {
      const std::vector<double>& group = g[pick_group(rng)];
      std::uniform_int_distribution<size_t> pick(0, group.size() - 1);
      for (size_t j = 0; j < group.size(); ++j) s += group[pick(rng)];
      n += group.size();
    }
    m = s / static_cast<double>(n);
  }
  std::sort(means.begin(), means.end());
  const double alpha = 0.5 * (1.0 - confidence);
  const auto at = [&](double q) {
    const double pos = q * (means.size() - 1);
    const size_t lo = static_cast<size_t>(std::floor(pos));
    const size_t hi = std::min(lo + 1, means.size() - 1);
    return means[lo] + (pos - lo) * (means[hi] - means[lo]);
  };
  return {mean, at(alpha), at(1.0 - alpha)};
}

Interval SeedMeanInterval(const std::vector<double>& per_seed) {
  // two-sided 97.5 % quantiles of Student's t for 1..10 degrees of freedom, then the normal value
  static constexpr double kT[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228};
  std::vector<double> x;
  for (double v : per_seed) {
    if (std::isfinite(v)) x.push_back(v);
  }
  if (x.empty()) return {kNaN, kNaN, kNaN};
  const double mean = FiniteMean(x);
  if (x.size() == 1) return {mean, kNaN, kNaN};
  double ss = 0.0;
  for (double v : x) ss += (v - mean) * (v - mean);
  const size_t dof = x.size() - 1;
  const double t = dof <= 10 ? kT[dof - 1] : 1.96;
  const double half = t * std::sqrt(ss / dof / x.size());
  return {mean, mean - half, mean + half};
}

double FiniteMean(const std::vector<double>& values) {
  double s = 0.0;
  int n = 0;
  for (double v : values) {
    if (std::isfinite(v)) {
      s += v;
      ++n;
    }
  }
  return n > 0 ? s / n : kNaN;
}

std::uint64_t LabelSeed(const std::string& label) {
  std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a, 64 bit
  for (unsigned char c : label) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

}  // namespace rmpmarl::experiments
