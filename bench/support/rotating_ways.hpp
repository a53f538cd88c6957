// The paired timing of issue 8's skip benchmarks (bench/scenes/scenes_bench.cpp,
// bench/plugins/fpga_host_bench.cpp): every iteration runs each way once, in an order that
// rotates from one iteration to the next, so that the machine's noise falls on all ways alike and
// their ratios hold where absolute times do not.
#pragma once

#include <benchmark/benchmark.h>

#include <array>
#include <chrono>

namespace rbdgrad::bench {

/// Calls run(way) for each of the kWays ways in every iteration of `state`, way (pass + j) % kWays
/// at step j of pass `pass`. Returns the nanoseconds spent in each way; `passes` gets the number
/// of iterations.
template <int kWays, class Run>
std::array<double, kWays> time_rotating_ways(benchmark::State& state, Run&& run, long& passes) {
  using Clock = std::chrono::steady_clock;
  std::array<double, kWays> ns{};
  passes = 0;
  for (auto _ : state) {
    for (int j = 0; j < kWays; ++j) {
      const int which = static_cast<int>((passes + j) % kWays);
      const Clock::time_point start = Clock::now();
      run(which);
      ns[which] += std::chrono::duration<double, std::nano>(Clock::now() - start).count();
    }
    ++passes;
  }
  return ns;
}

}  // namespace rbdgrad::bench
