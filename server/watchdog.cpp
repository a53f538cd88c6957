// The thread that gives up backend calls past their limit.
#include "watchdog.hpp"

#include <vector>

namespace rbdgrad::server {

Watchdog::Watchdog(std::function<void(const std::shared_ptr<CallAttempt>&)> expired)
    : expired_(std::move(expired)), thread_(&Watchdog::loop, this) {}

Watchdog::~Watchdog() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
  for (const auto& a : attempts_) a->listed_ = false;
}

void Watchdog::add(const std::shared_ptr<CallAttempt>& attempt) {
  bool sooner = false;
  {
    std::lock_guard lock(mutex_);
    attempt->where_ = attempts_.insert(attempts_.end(), attempt);
    attempt->listed_ = true;
    sooner = attempt->deadline < next_;
    if (sooner) next_ = attempt->deadline;
  }
  if (sooner) wake_.notify_one();
}

void Watchdog::remove(CallAttempt& attempt) {
  std::lock_guard lock(mutex_);
  if (!attempt.listed_) return;
  attempt.listed_ = false;
  attempts_.erase(attempt.where_);  // the list's own shared_ptr goes last: the caller holds another
}

void Watchdog::loop() {
  std::vector<std::shared_ptr<CallAttempt>> due;
  std::unique_lock lock(mutex_);
  while (!stop_) {
    const auto now = CallAttempt::Clock::now();
    next_ = CallAttempt::Clock::time_point::max();
    for (auto it = attempts_.begin(); it != attempts_.end();) {
      if ((*it)->deadline <= now) {
        (*it)->listed_ = false;
        due.push_back(std::move(*it));
        it = attempts_.erase(it);
      } else {
        next_ = std::min(next_, (*it)->deadline);
        ++it;
      }
    }
    if (!due.empty()) {
      lock.unlock();
      for (const auto& a : due) expired_(a);
      due.clear();
      lock.lock();
      continue;
    }
    if (next_ == CallAttempt::Clock::time_point::max()) {
      wake_.wait(lock);
    } else {
      wake_.wait_until(lock, next_);
    }
  }
}

}  // namespace rbdgrad::server
