#include "thread_pool.hpp"

#include <algorithm>
#include <chrono>

namespace rbdgrad::plugin {
namespace {

// about 20 microseconds of polling before a wait falls back to the condition variable
constexpr int kSpinIterations = 4000;

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

}  // namespace

template <class Ready>
void ThreadPool::poll_until(Ready&& ready) const {
  for (int i = 0; i < kSpinIterations; ++i) {
    if (ready()) return;
    cpu_relax();
  }
  if (idle_poll_.count() <= 0) return;
  const auto end = std::chrono::steady_clock::now() + idle_poll_;
  while (!ready() && std::chrono::steady_clock::now() < end) std::this_thread::yield();
}

ThreadPool::ThreadPool(std::size_t threads, std::chrono::microseconds idle_poll) : idle_poll_(idle_poll) {
  const std::size_t extra = threads > 1 ? threads - 1 : 0;
  threads_.reserve(extra);
  try {
    for (std::size_t w = 1; w <= extra; ++w) threads_.emplace_back(&ThreadPool::worker_loop, this, w);
  } catch (...) {
    // a thread failed to start: stop the ones that did before reporting it
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (std::thread& t : threads_) t.join();
    throw;
  }
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  start_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void ThreadPool::run_erased(std::size_t tasks, TaskFn fn, void* ctx) {
  if (tasks == 0) return;
  std::lock_guard serial(run_mutex_);
  bool wake = false;
  {
    std::lock_guard lock(mutex_);
    fn_ = fn;
    ctx_ = ctx;
    tasks_ = tasks;
    next_task_.store(0, std::memory_order_relaxed);
    error_ = nullptr;
    // only as many pool threads as there are tasks beyond the caller's take part (the caller
    // drains too): a small batch does not wait for every thread of a large pool to check in.
    // One task needs no hand-off: the pool threads stay asleep.
    participants_ = std::min(tasks - 1, threads_.size());
    wake = participants_ > 0;
    if (wake) {
      busy_ = participants_;
      ++generation_;
    }
  }
  if (wake) start_.notify_all();
  drain(0);
  poll_until([this] { return busy_.load(std::memory_order_acquire) == 0; });
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return busy_ == 0; });
  if (error_) {
    std::exception_ptr e = std::move(error_);
    error_ = nullptr;
    lock.unlock();
    std::rethrow_exception(e);
  }
}

void ThreadPool::worker_loop(std::size_t worker) {
  std::uint64_t seen = 0;
  for (;;) {
    poll_until([&] {
      return stop_.load(std::memory_order_acquire) || generation_.load(std::memory_order_acquire) != seen;
    });
    {
      std::unique_lock lock(mutex_);
      start_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      // not needed this time: back to waiting, uncounted (busy_ counts workers 1..participants_)
      if (worker > participants_) continue;
    }
    drain(worker);
    std::lock_guard lock(mutex_);
    if (--busy_ == 0) done_.notify_one();
  }
}

void ThreadPool::drain(std::size_t worker) {
  // the job fields were published under mutex_ before this worker saw the new generation
  for (std::size_t task; (task = next_task_.fetch_add(1, std::memory_order_relaxed)) < tasks_;) {
    try {
      fn_(ctx_, task, worker);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
  }
}

}  // namespace rbdgrad::plugin
