// A persistent pool of worker threads for batch computation. The threads start once, in the
// constructor, and wait between batches: spawning threads per batch cost up to 1.9x in the paper's
// measurements. Waiting spins briefly before it sleeps (workers for the next batch, the caller for
// the end of this one): waking a sleeping thread costs tens of microseconds, as much as a whole
// batch of 16 iiwa14 gradients per worker, and MPC loops send batches back to back. run() hands out tasks to the workers and the calling thread and blocks until all are
// done; it allocates nothing (the task is a function pointer plus a context pointer).
#pragma once

#include <atomic>
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
  /// \param[in] threads total parallelism, >= 1 (0 is taken as 1): the calling thread of run()
  ///            plus threads - 1 pool threads.
  explicit ThreadPool(std::size_t threads);
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
  void worker_loop(std::size_t worker);
  // takes tasks until none is left
  void drain(std::size_t worker);

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
  std::atomic<std::size_t> next_task_{0};
  std::exception_ptr error_;  // first exception of the current run
};

}  // namespace rbdgrad::plugin
