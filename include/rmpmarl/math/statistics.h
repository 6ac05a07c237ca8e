#pragma once
/// Rates and medians of episode outcomes: a point estimate with its interval, Wilson's score interval for a rate and
/// the median of finite values (the experiments' reports, the benchmark and the demo's success tables).
#include <vector>

namespace rmpmarl::math {

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

/// median of the finite values, the mean of the middle two for an even count (NaN when none).
double FiniteMedian(std::vector<double> values);

}  // namespace rmpmarl::math
