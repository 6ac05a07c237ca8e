#pragma once
/// 95 % confidence intervals of the experiment reports: Wilson's score interval for rates, the percentile bootstrap
/// for means (seeded, so a report is reproducible).
#include <cstdint>
#include <vector>

namespace rmpmarl::experiments {

/// a point estimate with its interval [low, high].
struct Interval {
  double value = 0.0;
  double low = 0.0;
  double high = 0.0;
};

/// Wilson score interval of `successes` out of `trials` at normal quantile z (1.96: 95 %). E. B. Wilson, "Probable
/// inference, the law of succession, and statistical inference", JASA 22 (1927):
///   centre = (p̂ + z²/2n) / (1 + z²/n),  half width = z √(p̂(1 − p̂)/n + z²/4n²) / (1 + z²/n).
/// trials = 0 gives NaNs.
Interval WilsonInterval(int successes, int trials, double z = 1.959963984540054);

/// mean of the finite `values` with a percentile-bootstrap interval (Efron & Tibshirani 1993, ch. 13) from
/// `resamples` resamples drawn with std::mt19937_64(seed). No finite value: NaNs.
Interval BootstrapMeanInterval(const std::vector<double>& values, std::uint64_t seed = 1, int resamples = 2000,
                               double confidence = 0.95);

}  // namespace rmpmarl::experiments
