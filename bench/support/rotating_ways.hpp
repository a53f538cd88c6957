// The paired timing of issue 8's skip benchmarks (bench/scenes/scenes_bench.cpp,
// bench/plugins/fpga_host_bench.cpp): every iteration runs each way once, in an order that
// rotates from one iteration to the next, so that the machine's noise falls on all ways alike and
// their ratios hold where absolute times do not.
#pragma once

#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <string>

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

/// The counters of three ways timed over `states` states in all: "<name>_ns" per state for each,
/// "speedup" (way 0 over way 1) and "<names[1]>_over_<names[2]>".
inline void report_three_ways(benchmark::State& state, const std::array<double, 3>& ns, double states,
                              const std::array<const char*, 3>& names) {
  for (int k = 0; k < 3; ++k) state.counters[std::string(names[k]) + "_ns"] = ns[k] / states;
  state.counters["speedup"] = ns[0] / ns[1];
  state.counters[std::string(names[1]) + "_over_" + names[2]] = ns[1] / ns[2];
}

}  // namespace rbdgrad::bench
