// Tests for plugins/cpu/thread_pool.cpp.
#include "thread_pool.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace rbdgrad::plugin {
namespace {

// runs `tasks` tasks and checks that each ran once, on a valid worker, never two at once per worker
void check_run(ThreadPool& pool, std::size_t tasks) {
  std::vector<std::atomic<int>> runs(tasks);
  std::vector<std::atomic<int>> in_use(pool.size());
  std::atomic<bool> overlap{false}, bad_worker{false};
  pool.run(tasks, [&](std::size_t task, std::size_t worker) {
    if (worker >= pool.size()) {
      bad_worker = true;
      return;
    }
    if (in_use[worker].fetch_add(1) != 0) overlap = true;
    runs[task].fetch_add(1);
    in_use[worker].fetch_sub(1);
  });
  for (std::size_t t = 0; t < tasks; ++t) ASSERT_EQ(runs[t].load(), 1) << "task " << t << " of " << tasks;
  EXPECT_FALSE(overlap);
  EXPECT_FALSE(bad_worker);
}

TEST(ThreadPool, EveryTaskRunsExactlyOnceForAnyTaskCount) {
  for (std::size_t threads : {1, 2, 3, 4, 8}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.size(), threads);
    // none, fewer tasks than workers, as many, many more
    for (std::size_t tasks : {std::size_t{0}, std::size_t{1}, threads - 1, threads, threads + 1, 10 * threads + 3, std::size_t{1000}})
      check_run(pool, tasks);
  }
}

// A run of fewer tasks than workers takes the caller and tasks - 1 pool threads only (worker
// indices below the task count): it never waits for the others. Runs of every size alternate so
// that threads left out of one run take part in the next.
TEST(ThreadPool, ASmallRunUsesOnlyAsManyWorkersAsTasks) {
  ThreadPool pool(8);
  for (int round = 0; round < 300; ++round) {
    const std::size_t tasks = 1 + static_cast<std::size_t>(round * 7 % 12);
    std::atomic<std::size_t> highest{0};
    std::vector<std::atomic<int>> runs(tasks);
    pool.run(tasks, [&](std::size_t task, std::size_t worker) {
      runs[task].fetch_add(1);
      for (std::size_t h = highest.load(); worker > h && !highest.compare_exchange_weak(h, worker);) {
      }
      if (round % 5 == 0) std::this_thread::sleep_for(std::chrono::microseconds(50));
    });
    for (std::size_t t = 0; t < tasks; ++t) ASSERT_EQ(runs[t].load(), 1) << "round " << round << ", task " << t;
    EXPECT_LT(highest.load(), std::min(tasks, pool.size())) << "round " << round << ": " << tasks << " tasks";
  }
}

TEST(ThreadPool, ZeroThreadsMeansTheCallerAlone) {
  ThreadPool pool(0);
  EXPECT_EQ(pool.size(), 1u);
  std::set<std::thread::id> ids;
  pool.run(5, [&](std::size_t, std::size_t worker) {
    EXPECT_EQ(worker, 0u);
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(ids, std::set<std::thread::id>{std::this_thread::get_id()});
}

TEST(ThreadPool, OneThreadRunsInOrderOnTheCaller) {
  ThreadPool pool(1);
  std::vector<std::size_t> order;
  pool.run(6, [&](std::size_t task, std::size_t worker) {
    EXPECT_EQ(worker, 0u);
    order.push_back(task);
  });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4, 5}));
}

TEST(ThreadPool, ResultsAreDeterministicOverManyRuns) {
  ThreadPool pool(4);
  std::vector<double> reference;
  for (int run = 0; run < 200; ++run) {
    std::vector<double> out(64, 0.0);
    pool.run(out.size(), [&](std::size_t task, std::size_t) {
      double x = 0;
      for (std::size_t i = 1; i <= 100 + task; ++i) x += 1.0 / static_cast<double>(i * (task + 1));
      out[task] = x;
    });
    if (run == 0) reference = out;
    ASSERT_EQ(out, reference) << "run " << run;
  }
}

TEST(ThreadPool, UsesThePoolThreads) {
  ThreadPool pool(4);
  std::mutex mutex;
  std::set<std::thread::id> ids;
  std::atomic<int> arrived{0};
  // each task waits until all four have started: only four distinct threads can get there
  pool.run(4, [&](std::size_t, std::size_t) {
    {
      std::lock_guard lock(mutex);
      ids.insert(std::this_thread::get_id());
    }
    arrived.fetch_add(1);
    while (arrived.load() < 4) std::this_thread::yield();
  });
  EXPECT_EQ(ids.size(), 4u);
  EXPECT_TRUE(ids.count(std::this_thread::get_id()));
}

TEST(ThreadPool, WorkersThatWentToSleepWakeForTheNextRun) {
  // with no idle polling and with a short one, the workers sleep between these runs
  for (const auto idle_poll : {std::chrono::microseconds(0), std::chrono::microseconds(100)}) {
    ThreadPool pool(3, idle_poll);
    for (int run = 0; run < 3; ++run) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      std::mutex mutex;
      std::set<std::thread::id> ids;
      std::atomic<int> arrived{0};
      pool.run(3, [&](std::size_t, std::size_t) {
        {
          std::lock_guard lock(mutex);
          ids.insert(std::this_thread::get_id());
        }
        arrived.fetch_add(1);
        while (arrived.load() < 3) std::this_thread::yield();
      });
      EXPECT_EQ(ids.size(), 3u) << "idle_poll " << idle_poll.count() << " us, run " << run;
    }
  }
}

TEST(ThreadPool, AnExceptionIsRethrownAfterAllTasksRan) {
  ThreadPool pool(3);
  std::atomic<int> ran{0};
  EXPECT_THROW(pool.run(20,
                        [&](std::size_t task, std::size_t) {
                          ran.fetch_add(1);
                          if (task == 7) throw std::runtime_error("task 7");
                        }),
               std::runtime_error);
  EXPECT_EQ(ran.load(), 20);
  // and the pool still works
  check_run(pool, 50);
}

TEST(ThreadPool, DestructionWhileIdle) {
  for (int i = 0; i < 20; ++i) {
    ThreadPool never_used(4);
    ThreadPool used_once(3);
    check_run(used_once, 10);
  }
}

TEST(ThreadPool, RunsFromAnotherThreadAreSerialised) {
  ThreadPool pool(3);
  std::atomic<int> inside{0};
  std::atomic<bool> overlap{false};
  auto body = [&] {
    for (int r = 0; r < 50; ++r)
      pool.run(6, [&](std::size_t, std::size_t worker) {
        if (worker == 0 && inside.fetch_add(1) != 0) overlap = true;
        if (worker == 0) inside.fetch_sub(1);
      });
  };
  std::thread other(body);
  body();
  other.join();
  EXPECT_FALSE(overlap);
}

}  // namespace
}  // namespace rbdgrad::plugin
