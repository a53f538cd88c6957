// Tests for server/watchdog.cpp: attempts past their deadline are handed to the callback once, in
// time; removed ones never are.
#include "watchdog.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace rbdgrad::server {
namespace {

using Clock = CallAttempt::Clock;
using namespace std::chrono_literals;

std::shared_ptr<CallAttempt> attempt_due_in(Clock::duration d) {
  auto a = std::make_shared<CallAttempt>();
  a->started = Clock::now();
  a->deadline = a->started + d;
  return a;
}

TEST(Watchdog, HandsOverDueAttemptsOnceAndForgetsRemovedOnes) {
  std::mutex mutex;
  std::vector<std::pair<CallAttempt*, Clock::time_point>> fired;
  Watchdog watchdog([&](const std::shared_ptr<CallAttempt>& a) {
    std::lock_guard lock(mutex);
    fired.emplace_back(a.get(), Clock::now());
  });
  const auto late = attempt_due_in(150ms);
  const auto early = attempt_due_in(50ms);  // added after a later one: the thread wakes sooner
  const auto removed = attempt_due_in(100ms);
  watchdog.add(late);
  watchdog.add(early);
  watchdog.add(removed);
  watchdog.remove(*removed);
  watchdog.remove(*removed);  // twice: nothing
  std::this_thread::sleep_for(400ms);
  std::lock_guard lock(mutex);
  ASSERT_EQ(fired.size(), 2u);
  EXPECT_EQ(fired[0].first, early.get());
  EXPECT_EQ(fired[1].first, late.get());
  EXPECT_GE(fired[0].second, early->deadline);
  EXPECT_LT(fired[0].second, early->deadline + 100ms) << "woken for the earlier deadline";
  EXPECT_GE(fired[1].second, late->deadline);
  watchdog.remove(*late);  // no longer listed: nothing
}

TEST(Watchdog, StopsWithAttemptsStillListed) {
  std::atomic<int> fired{0};
  const auto a = attempt_due_in(std::chrono::hours(1));
  {
    Watchdog watchdog([&](const std::shared_ptr<CallAttempt>&) { ++fired; });
    watchdog.add(a);
  }
  EXPECT_EQ(fired.load(), 0);
  EXPECT_EQ(a.use_count(), 1) << "the watchdog let go of it";
}

}  // namespace
}  // namespace rbdgrad::server
