// Latency summaries (see latency_stats.hpp).
#include "latency_stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rbdgrad::bench {

double nearest_rank(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0;
  // rank ceil(p * n), 1-based; the small epsilon keeps 0.99 * 100 from rounding up to 100
  auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size()) - 1e-9));
  rank = std::clamp<std::size_t>(rank, 1, sorted.size());
  return sorted[rank - 1];
}

LatencySummary summarize(std::vector<double>& samples_us) {
  LatencySummary s;
  if (samples_us.empty()) return s;
  std::sort(samples_us.begin(), samples_us.end());
  s.count = samples_us.size();
  s.p50_us = nearest_rank(samples_us, 0.50);
  s.p99_us = nearest_rank(samples_us, 0.99);
  s.mean_us = std::accumulate(samples_us.begin(), samples_us.end(), 0.0) / static_cast<double>(s.count);
  s.min_us = samples_us.front();
  s.max_us = samples_us.back();
  return s;
}

}  // namespace rbdgrad::bench
