#pragma once
/// 95 % confidence intervals of the experiment reports: Wilson's score interval for rates, the percentile bootstrap
/// for means (seeded, so a report is reproducible).
#include <cstdint>
#include <string>
#include <vector>

#include "rmpmarl/math/statistics.h"

namespace rmpmarl::experiments {

/// a point estimate with its interval, Wilson's score interval for rates and the median of finite values
/// (math/statistics.h)
using math::FiniteMedian;
using math::Interval;
using math::WilsonInterval;

/// mean of the finite `values` with a percentile-bootstrap interval (Efron & Tibshirani 1993, ch. 13) from
/// `resamples` resamples drawn with std::mt19937_64(seed). No finite value: NaNs.
Interval BootstrapMeanInterval(const std::vector<double>& values, std::uint64_t seed = 1, int resamples = 2000,
                               double confidence = 0.95);

/// the same for values grouped by training seed (episodes of one seed form a group): a two-level bootstrap that
/// resamples the groups, then the values within each drawn group (Davison & Hinkley 1997, sec. 3.8), so the interval
/// carries the seed-to-seed spread and does not count shared episodes as independent. One group: the plain bootstrap.
Interval HierarchicalBootstrapMeanInterval(const std::vector<std::vector<double>>& groups, std::uint64_t seed = 1,
                                           int resamples = 2000, double confidence = 0.95);

/// mean of per-seed values with the 95 % Student-t interval mean ± t(0.975, n − 1) s / √n (n = 1: NaN bounds).
Interval SeedMeanInterval(const std::vector<double>& per_seed);

/// mean of the finite values (NaN when none).
double FiniteMean(const std::vector<double>& values);

/// a stable seed from a label (FNV-1a), so an interval does not depend on which other rows a report has.
std::uint64_t LabelSeed(const std::string& label);

}  // namespace rmpmarl::experiments
