// Dynamic batching: concurrent small requests for the same backend pool, precision, input kind
// and outputs are held up to a configured delay and computed in one backend call, as inference
// servers do; each caller gets exactly its own results. A group goes to its pool when it reaches
// the preferred size or when its first request has waited the delay. States are independent in
// every backend, so a state's outputs are the same whether it was computed alone or in a group;
// a request with a failed state is computed again on its own (the usual path, with its exact
// error message, its failover and its fixed-point fallback).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <thread>
#include <tuple>
#include <vector>

#include "instance_pool.hpp"

namespace rbdgrad::server {

class ComputeCall;

class Coalescer {
 public:
  using Clock = std::chrono::steady_clock;

  /// `max_delay` > 0; groups of at least `preferred_states` states go at once.
  Coalescer(std::chrono::microseconds max_delay, std::uint64_t preferred_states);
  /// Sends whatever is pending to its pools (no accepted request is dropped), then stops.
  ~Coalescer();
  Coalescer(const Coalescer&) = delete;
  Coalescer& operator=(const Coalescer&) = delete;

  /// Whether `call` (prepared) may wait for others: smaller than the preferred size, not fixed
  /// point (its fallback re-runs states per request).
  bool takes(const ComputeCall& call) const;

  /// Holds `call` for its group (taken by takes()). Thread-safe.
  void add(ComputeCall& call);

  std::chrono::microseconds max_delay() const noexcept { return max_delay_; }
  std::uint64_t preferred_states() const noexcept { return preferred_; }

 private:
  // requests that can share one backend call
  using Key = std::tuple<InstancePool*, std::uint32_t /*precision*/, std::uint32_t /*input*/, std::uint32_t /*outputs*/,
                         bool /*minv*/, bool /*fext*/>;
  struct Group {
    std::vector<ComputeCall*> calls;
    std::uint64_t states = 0;
    Clock::time_point due;  // first arrival + max_delay
  };

  void timer_loop();
  // hands a group to its pool (outside mutex_)
  static void send(InstancePool* pool, std::vector<ComputeCall*> calls, std::uint64_t states);

  const std::chrono::microseconds max_delay_;
  const std::uint64_t preferred_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<Key, Group> groups_;
  bool stop_ = false;
  std::thread timer_;  // last: started once the rest exists
};

}  // namespace rbdgrad::server
