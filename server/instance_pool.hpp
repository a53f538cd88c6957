// The plugin instances of one (model, backend) pair and the FIFO queue of jobs waiting for one.
// The ABI forbids concurrent compute on an instance, so each job gets exclusive use of one: on
// one of the pool's threads, one per instance, which take queued jobs in arrival order (or, when
// enabled, on the submitting thread when an instance is free and nothing waits). The threads
// start here, once: no thread is created per request.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "plugin_loader.hpp"

namespace rbdgrad::server {

// One unit of work. The submitter owns it and keeps it alive until run() has returned; run()
// usually completes the request and lets its owner go, so the pool never touches a job after
// calling run().
class InstancePool;

class PoolJob {
 public:
  /// Runs with exclusive use of `instance`. Must not throw.
  virtual void run(PluginInstance& instance) noexcept = 0;

 protected:
  PoolJob() = default;
  PoolJob(const PoolJob&) = default;
  PoolJob& operator=(const PoolJob&) = default;
  virtual ~PoolJob() = default;

  /// From run(), once the job is done with the instance and before it answers its request: the
  /// instance is free again at once, so that the client's next request does not find it busy (and
  /// routed elsewhere). Not after the job was submitted again; a second call does nothing.
  void release_instance() noexcept;

 private:
  friend class InstancePool;
  PoolJob* next_ = nullptr;  // intrusive FIFO link: queueing allocates nothing
  double predicted_us_ = 0;  // the scheduler's prediction, counted in the pool's pending work
  // where the job runs, set by the pool before run()
  InstancePool* pool_ = nullptr;
  std::size_t instance_ = 0;
  std::uint64_t lease_ = 0;
};

// What a pool has to do, for the scheduler and GetServerInfo.
struct PoolLoad {
  std::size_t queued = 0;   // jobs waiting for an instance
  std::size_t running = 0;  // instances computing
  // the predicted time of the jobs queued and running; a running job that has overrun its
  // prediction counts at the time it has run so far (it is expected to take as long again)
  double pending_us = 0;
};

class InstancePool {
 public:
  struct Options {
    // Jobs of at most this many states run on the submitting thread when an instance is free and
    // no job is queued; larger ones go to a pool thread. 0 = never inline. The daemon sets it from
    // its configuration (inline_max_states): on 2 cores, iiwa14 N = 64 over a local socket, inline
    // cut the server's queue time from 24-43 us to 8-28 us and the round trip in 8 of 8
    // comparisons (docs/benchmarks/service.md).
    std::uint64_t inline_max_states = 0;
  };

  /// Takes `instances` (at least one) and starts one thread per instance.
  InstancePool(std::vector<std::unique_ptr<PluginInstance>> instances, Options options);
  /// Runs every job still queued, then joins the threads. No submit() may overlap or follow it.
  ~InstancePool();
  InstancePool(const InstancePool&) = delete;
  InstancePool& operator=(const InstancePool&) = delete;

  /// Runs `job` (of `num_states` states) exactly once, now on this thread or later on a pool
  /// thread, in submission order relative to the other queued jobs. Never blocks on a busy
  /// instance. Thread-safe. `predicted_us`, the scheduler's prediction of the job's compute
  /// time, counts in load().pending_us until the job has run.
  void submit(PoolJob& job, std::uint64_t num_states, double predicted_us = 0);

  std::size_t size() const noexcept { return instances_.size(); }
  /// Instance i, for what the ABI allows at any time (describe, estimate_latency); never compute.
  const PluginInstance& instance(std::size_t i) const { return *instances_[i]; }

  /// The work queued and running now. Thread-safe.
  PoolLoad load() const;
  /// How long a job submitted now would wait for an instance, by the predictions: the pending
  /// work (load().pending_us) spread over the instances. An instance that hangs makes it grow
  /// with the time it has hung, so the cost policy routes around it and deadlines see it.
  /// Thread-safe.
  double predicted_wait_us() const;

 private:
  friend class PoolJob;
  using Clock = std::chrono::steady_clock;
  // what runs on instance i: since when, its prediction, and the lease it runs under (0: none)
  struct Running {
    Clock::time_point since{};
    double predicted_us = 0;
    std::uint64_t lease = 0;
  };

  void thread_loop();
  // under mutex_: hands a free instance to the queue's head, if both exist
  bool take_work(PoolJob*& job, std::size_t& instance);
  // under mutex_: marks instance i busy with `job`, predicted to take predicted_us, under a new
  // lease that the job carries
  void start_running(std::size_t i, PoolJob& job, double predicted_us);
  // returns instance i and takes the finished job's prediction off the pending work, once per
  // lease: after the job's release_instance(), the pool's own give-back does nothing
  void give_back(std::size_t i, std::uint64_t lease);
  // runs `job` on instance i, then gives the instance back (unless the job did)
  void run_on(PoolJob& job, std::size_t i);
  // under mutex_: pending_us_ plus what the running jobs have overrun their predictions by
  double pending_locked() const;

  const Options options_;
  std::vector<std::unique_ptr<PluginInstance>> instances_;

  mutable std::mutex mutex_;
  std::size_t queued_ = 0;   // jobs in the FIFO
  double pending_us_ = 0;    // predictions of the queued and running jobs
  std::condition_variable work_;       // a job and a free instance, or stop_
  std::vector<std::size_t> free_;      // indices of free instances; (size()) reserved once
  std::vector<Running> running_;       // (size()), entry i meaningful while i is not free
  std::uint64_t next_lease_ = 0;
  PoolJob* head_ = nullptr;            // FIFO of waiting jobs
  PoolJob* tail_ = nullptr;
  bool stop_ = false;
  std::vector<std::thread> threads_;   // last: started after everything above exists
};

}  // namespace rbdgrad::server
