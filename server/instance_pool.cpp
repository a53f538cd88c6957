// Exclusive use of plugin instances: inline when free, else a FIFO served by one thread per instance.
#include "instance_pool.hpp"

#include <algorithm>
#include <utility>

namespace rbdgrad::server {

InstancePool::InstancePool(std::vector<std::unique_ptr<PluginInstance>> instances, Options options)
    : options_(options), instances_(std::move(instances)) {
  free_.reserve(instances_.size());
  for (std::size_t i = 0; i < instances_.size(); ++i) free_.push_back(i);
  running_.resize(instances_.size());
  threads_.reserve(instances_.size());
  for (std::size_t i = 0; i < instances_.size(); ++i) threads_.emplace_back(&InstancePool::thread_loop, this);
}

InstancePool::~InstancePool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  for (std::thread& t : threads_) t.join();
}

bool InstancePool::take_work(PoolJob*& job, std::size_t& instance) {
  if (head_ == nullptr || free_.empty()) return false;
  job = std::exchange(head_, head_->next_);
  if (head_ == nullptr) tail_ = nullptr;
  --queued_;
  job->next_ = nullptr;
  instance = free_.back();
  free_.pop_back();
  start_running(instance, *job, job->predicted_us_);
  return true;
}

void InstancePool::start_running(std::size_t i, PoolJob& job, double predicted_us) {
  running_[i] = {Clock::now(), predicted_us, ++next_lease_};
  job.pool_ = this;
  job.instance_ = i;
  job.lease_ = next_lease_;
}

void PoolJob::release_instance() noexcept {
  if (pool_ == nullptr) return;
  InstancePool* pool = std::exchange(pool_, nullptr);
  pool->give_back(instance_, lease_);
}

void InstancePool::run_on(PoolJob& job, std::size_t i) {
  // the job may be gone after run (and its fields with it): the lease is read first
  const std::uint64_t lease = job.lease_;
  job.run(*instances_[i]);
  give_back(i, lease);
}

void InstancePool::give_back(std::size_t i, std::uint64_t lease) {
  bool queued = false;
  {
    std::lock_guard lock(mutex_);
    if (running_[i].lease != lease) return;  // given back already (release_instance)
    running_[i].lease = 0;
    free_.push_back(i);
    queued = head_ != nullptr;
    pending_us_ -= running_[i].predicted_us;
    // rounding must not leave a phantom backlog once everything has run
    if (head_ == nullptr && free_.size() == instances_.size()) pending_us_ = 0;
  }
  // a job queued while every instance was busy: a pool thread takes it now
  if (queued) work_.notify_one();
}

void InstancePool::submit(PoolJob& job, std::uint64_t num_states, double predicted_us) {
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::size_t instance = kNone;
  job.predicted_us_ = predicted_us;
  {
    std::lock_guard lock(mutex_);
    pending_us_ += predicted_us;
    // inline only when nothing waits: a job never overtakes an earlier one
    if (num_states <= options_.inline_max_states && head_ == nullptr && !free_.empty()) {
      instance = free_.back();
      free_.pop_back();
      start_running(instance, job, predicted_us);
    } else {
      job.next_ = nullptr;
      if (tail_ != nullptr) {
        tail_->next_ = &job;
      } else {
        head_ = &job;
      }
      tail_ = &job;
      ++queued_;
    }
  }
  if (instance == kNone) {
    work_.notify_one();
    return;
  }
  run_on(job, instance);
}

double InstancePool::pending_locked() const {
  if (free_.size() == instances_.size()) return pending_us_;
  // free_ is small (one entry per instance): a running instance is one not in it
  const Clock::time_point now = Clock::now();
  double overrun_us = 0;
  for (std::size_t i = 0; i < running_.size(); ++i) {
    if (std::find(free_.begin(), free_.end(), i) != free_.end()) continue;
    const double elapsed_us = std::chrono::duration<double, std::micro>(now - running_[i].since).count();
    overrun_us += std::max(0.0, elapsed_us - running_[i].predicted_us);
  }
  return pending_us_ + overrun_us;
}

PoolLoad InstancePool::load() const {
  std::lock_guard lock(mutex_);
  return {queued_, instances_.size() - free_.size(), pending_locked()};
}

double InstancePool::predicted_wait_us() const {
  std::lock_guard lock(mutex_);
  // an instance is free and nothing waits: no wait, whatever runs elsewhere
  if (head_ == nullptr && !free_.empty()) return 0;
  return pending_locked() / static_cast<double>(instances_.size());
}

void InstancePool::thread_loop() {
  for (;;) {
    PoolJob* job = nullptr;
    std::size_t instance = 0;
    {
      std::unique_lock lock(mutex_);
      // stop only once the queue is empty: an accepted job is never dropped
      work_.wait(lock, [&] { return take_work(job, instance) || (stop_ && head_ == nullptr); });
      if (job == nullptr) return;
    }
    run_on(*job, instance);
  }
}

}  // namespace rbdgrad::server
