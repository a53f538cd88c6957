// A persistent pool of worker threads for batch computation. The threads start once, in the
// constructor, and wait between batches: spawning threads per batch cost up to 1.9x in the paper's
// measurements. Waiting polls before it sleeps (workers for the next batch, the caller for the end
// of this one): waking a sleeping thread costs tens of microseconds, as much as a whole batch of
// 16 iiwa14 gradients per worker, and MPC loops send batches back to back. Polling is a short busy
// spin (~20 us, for batches back to back in one process) followed by `idle_poll` of polling that
// yields the core to any other runnable thread: that phase bridges a client's round trip through
// the daemon (a few hundred us), costing a core only while nothing else wants it.
// run() hands out tasks to the calling thread and as many workers as the tasks need (a small batch
// does not wait for a large pool to check in) and blocks until all are done; it
// allocates nothing (the task is a function pointer plus a context pointer).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace rbdgrad::plugin {

class ThreadPool {
 public:
  /// Default of the yielding poll phase: longer than a round trip through the daemon over a
  /// local socket (measured in docs/benchmarks/service.md).
  static constexpr std::chrono::microseconds kDefaultIdlePoll{1000};

  /// \param[in] threads total parallelism, >= 1 (0 is taken as 1): the calling thread of run()
  ///            plus threads - 1 pool threads.
  /// \param[in] idle_poll how long a waiting thread keeps polling, yielding, after its short busy
  ///            spin and before it sleeps; 0 = sleep right after the spin.
  explicit ThreadPool(std::size_t threads, std::chrono::microseconds idle_poll = kDefaultIdlePoll);
  /// Stops and joins the threads; must not overlap a run().
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// Number of workers, the calling thread included: worker indices are in [0, size()).
  std::size_t size() const { return threads_.size() + 1; }

  /// Calls fn(task, worker) once for every task in [0, tasks), spread over the workers, and returns
  /// when all calls have returned. At most one call runs on a worker index at a time, so per-worker
  /// state indexed by `worker` needs no lock. Worker 0 is the calling thread. Calls of run() are
  /// serialised. If fn throws, the remaining tasks still run and the first exception is rethrown here.
  template <class F>
  void run(std::size_t tasks, F&& fn) {
    using Fn = std::remove_reference_t<F>;
    run_erased(tasks, [](void* ctx, std::size_t task, std::size_t worker) { (*static_cast<Fn*>(ctx))(task, worker); },
               const_cast<void*>(static_cast<const void*>(std::addressof(fn))));
  }

 private:
  using TaskFn = void (*)(void* ctx, std::size_t task, std::size_t worker);

  void run_erased(std::size_t tasks, TaskFn fn, void* ctx);
  // polls `ready` (busy, then yielding); the caller then waits properly under the lock either way
  template <class Ready>
  void poll_until(Ready&& ready) const;
  void worker_loop(std::size_t worker);
  // takes tasks until none is left
  void drain(std::size_t worker);

  const std::chrono::microseconds idle_poll_;
  std::vector<std::thread> threads_;
  std::mutex run_mutex_;  // one run() at a time

  // the current job, written under mutex_ before generation_ moves on
  std::mutex mutex_;
  std::condition_variable start_;  // generation_ changed or stop_
  std::condition_variable done_;   // busy_ reached 0
  // written under mutex_; atomic so that the spin phases can read them without the lock
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> busy_{0};  // pool threads still working on the current generation
  TaskFn fn_ = nullptr;
  void* ctx_ = nullptr;
  std::size_t tasks_ = 0;
  std::size_t participants_ = 0;  // pool threads 1..participants_ work on the current generation
  std::atomic<std::size_t> next_task_{0};
  std::exception_ptr error_;  // first exception of the current run
};

}  // namespace rbdgrad::plugin
