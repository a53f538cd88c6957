// Summary statistics of a set of latency samples (microseconds): count, p50, p99, mean, min, max.
#pragma once

#include <cstddef>
#include <vector>

namespace rbdgrad::bench {

struct LatencySummary {
  std::size_t count = 0;
  double p50_us = 0, p99_us = 0, mean_us = 0, min_us = 0, max_us = 0;
};

/// Percentiles by the nearest-rank rule (p99 of 100 samples is the 99th smallest, of 50 the largest).
/// Sorts `samples_us`. All zero for an empty set.
LatencySummary summarize(std::vector<double>& samples_us);

/// The nearest-rank `p`-quantile (0 < p <= 1) of sorted samples; 0 for an empty set.
double nearest_rank(const std::vector<double>& sorted, double p);

}  // namespace rbdgrad::bench
