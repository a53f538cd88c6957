// The order statistics the accuracy tests report over their states' errors.
#pragma once

#include <algorithm>
#include <vector>

namespace rbdgrad::testing {

// The middle of v (the upper of the two middles for an even size); 0 for none.
inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The largest of v; 0 for none.
inline double worst_of(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

}  // namespace rbdgrad::testing
