// What the CUDA probes (cuda_graph_probe.cu, cuda_persistent_probe.cu) share: a CUDA call's error
// reported, and the median time of a synchronous call pattern.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <vector>

namespace rbdgrad::probe {

// true when e is cudaSuccess; else prints "what: error" and returns false
inline bool ok(cudaError_t e, const char* what) {
  if (e == cudaSuccess) return true;
  std::fprintf(stderr, "%s: %s\n", what, cudaGetErrorString(e));
  return false;
}

// the median of 2000 timed calls after 200 warm-up calls, µs
inline double median_us(const std::function<void()>& call) {
  for (int k = 0; k < 200; ++k) call();
  std::vector<double> us;
  us.reserve(2000);
  for (int k = 0; k < 2000; ++k) {
    const auto start = std::chrono::steady_clock::now();
    call();
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(us.begin(), us.begin() + 1000, us.end());
  return us[1000];
}

}  // namespace rbdgrad::probe
