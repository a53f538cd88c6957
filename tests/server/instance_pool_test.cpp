// Tests for server/instance_pool.cpp, with instances of the fake_ok backend.
#include "instance_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace rbdgrad::server {
namespace {

// instances of fake_ok (it reads only nv from the model)
std::vector<std::unique_ptr<PluginInstance>> fake_instances(std::size_t count, std::unique_ptr<Plugin>& plugin) {
  std::vector<std::unique_ptr<PluginInstance>> out;
  if (!Plugin::load(FAKE_OK_PATH, plugin).is_ok()) return out;
  rbdgrad_model_desc model{};
  model.struct_size = sizeof(model);
  model.name = "two";
  model.nv = 2;
  for (std::size_t i = 0; i < count; ++i) {
    std::unique_ptr<PluginInstance> instance;
    if (!plugin->create_instance(model, {}, instance).is_ok()) return {};
    out.push_back(std::move(instance));
  }
  return out;
}

// Records where and in which order it ran, and whether its instance was in use by another job.
struct Recorder {
  std::mutex mutex;
  std::vector<int> order;
  std::map<PluginInstance*, std::atomic<int>> busy;
  std::atomic<int> overlaps{0};
};

class RecordingJob final : public PoolJob {
 public:
  RecordingJob(int id, Recorder& recorder, std::chrono::microseconds work = {}) : id_(id), rec_(recorder), work_(work) {}
  void run(PluginInstance& instance) noexcept override {
    ran_on = std::this_thread::get_id();
    std::atomic<int>* busy = nullptr;
    {
      std::lock_guard lock(rec_.mutex);
      rec_.order.push_back(id_);
      busy = &rec_.busy[&instance];
    }
    if (busy->fetch_add(1) != 0) ++rec_.overlaps;
    if (work_.count() > 0) std::this_thread::sleep_for(work_);
    busy->fetch_sub(1);
    done = true;
  }
  std::thread::id ran_on;
  std::atomic<bool> done{false};

 private:
  int id_;
  Recorder& rec_;
  std::chrono::microseconds work_;
};

// A job that gives its instance back before it returns (as a request does before it answers),
// then looks at the pool: the instance is free, and a second job runs on it meanwhile.
class ReleasingJob final : public PoolJob {
 public:
  ReleasingJob(InstancePool& pool, PoolJob& next) : pool_(pool), next_(next) {}
  void run(PluginInstance&) noexcept override {
    release_instance();
    release_instance();  // a second call does nothing
    load_after_release = pool_.load();
    wait_after_release = pool_.predicted_wait_us();
    pool_.submit(next_, 1, 100.0);  // inline: the released instance is free
  }
  PoolLoad load_after_release;
  double wait_after_release = -1;

 private:
  InstancePool& pool_;
  PoolJob& next_;
};

TEST(InstancePool, AJobThatReleasesItsInstanceFreesItBeforeItReturns) {
  std::unique_ptr<Plugin> plugin;
  auto instances = fake_instances(1, plugin);
  Recorder rec;
  InstancePool pool(std::move(instances), InstancePool::Options{16});
  RecordingJob next(1, rec);
  ReleasingJob job(pool, next);
  pool.submit(job, 1, 500.0);
  EXPECT_EQ(job.load_after_release.running, 0u) << "released: not running any more";
  EXPECT_EQ(job.load_after_release.pending_us, 0.0) << "its prediction is off the pending work";
  EXPECT_EQ(job.wait_after_release, 0.0);
  EXPECT_TRUE(next.done) << "the second job ran inline on the released instance";
  // the pool's own give-back after run() did not free the instance a second time
  const PoolLoad after = pool.load();
  EXPECT_EQ(after.running, 0u);
  EXPECT_EQ(after.pending_us, 0.0);
  // and the instance is used by one job at a time afterwards
  RecordingJob a(2, rec), b(3, rec, std::chrono::microseconds(20000));
  pool.submit(b, 100);  // on the pool thread
  pool.submit(a, 1);    // inline if the instance is free, else after b
  while (!a.done || !b.done) std::this_thread::yield();
  EXPECT_EQ(rec.overlaps.load(), 0);
}

TEST(InstancePool, RunsSmallJobsInlineAndLargeOnesOnItsThread) {
  std::unique_ptr<Plugin> plugin;
  auto instances = fake_instances(1, plugin);
  ASSERT_EQ(instances.size(), 1u);
  Recorder rec;
  InstancePool pool(std::move(instances), InstancePool::Options{16});
  EXPECT_EQ(pool.size(), 1u);

  RecordingJob small(0, rec);
  pool.submit(small, 16);
  EXPECT_TRUE(small.done);  // ran before submit returned
  EXPECT_EQ(small.ran_on, std::this_thread::get_id());

  RecordingJob large(1, rec);
  pool.submit(large, 17);
  while (!large.done) std::this_thread::yield();
  EXPECT_NE(large.ran_on, std::this_thread::get_id());
}

TEST(InstancePool, QueuedJobsRunInSubmissionOrder) {
  std::unique_ptr<Plugin> plugin;
  auto instances = fake_instances(1, plugin);
  ASSERT_EQ(instances.size(), 1u);
  Recorder rec;
  std::vector<std::unique_ptr<RecordingJob>> jobs;
  {
    InstancePool pool(std::move(instances), InstancePool::Options{0});  // never inline
    for (int i = 0; i < 50; ++i) {
      jobs.push_back(std::make_unique<RecordingJob>(i, rec, std::chrono::microseconds(i % 3 == 0 ? 200 : 0)));
      pool.submit(*jobs.back(), 1);
    }
  }  // the destructor runs what is still queued before it returns
  std::vector<int> expected(50);
  for (int i = 0; i < 50; ++i) expected[i] = i;
  EXPECT_EQ(rec.order, expected);
}

TEST(InstancePool, NeverRunsTwoJobsOnOneInstanceAtOnce) {
  std::unique_ptr<Plugin> plugin;
  auto instances = fake_instances(2, plugin);
  ASSERT_EQ(instances.size(), 2u);
  Recorder rec;
  constexpr int kThreads = 4, kPerThread = 100;
  std::vector<std::unique_ptr<RecordingJob>> jobs;
  for (int i = 0; i < kThreads * kPerThread; ++i) {
    jobs.push_back(std::make_unique<RecordingJob>(i, rec, std::chrono::microseconds(i % 7 == 0 ? 50 : 0)));
  }
  {
    InstancePool pool(std::move(instances), InstancePool::Options{});
    std::vector<std::thread> submitters;
    for (int t = 0; t < kThreads; ++t) {
      submitters.emplace_back([&, t] {
        // a mix of inline-sized and queued jobs
        for (int i = 0; i < kPerThread; ++i) pool.submit(*jobs[t * kPerThread + i], i % 2 == 0 ? 1 : 100000);
      });
    }
    for (std::thread& t : submitters) t.join();
  }
  EXPECT_EQ(rec.order.size(), static_cast<std::size_t>(kThreads * kPerThread));
  EXPECT_EQ(rec.overlaps.load(), 0);
}

// A job that runs until released, for the pending-work tests.
class BlockingJob final : public PoolJob {
 public:
  void run(PluginInstance&) noexcept override {
    started = true;
    while (!release) std::this_thread::sleep_for(std::chrono::microseconds(100));
    done = true;
  }
  std::atomic<bool> started{false}, release{false}, done{false};
};

// The predicted wait counts queued and running predictions, and a running job past its
// prediction at the time it has run (a hung instance is avoided by the cost policy).
TEST(InstancePool, PredictedWaitGrowsWhileAJobOverrunsItsPrediction) {
  std::unique_ptr<Plugin> plugin;
  auto instances = fake_instances(1, plugin);
  ASSERT_EQ(instances.size(), 1u);
  InstancePool pool(std::move(instances), InstancePool::Options{0});
  EXPECT_EQ(pool.predicted_wait_us(), 0.0);
  BlockingJob hung, queued;
  pool.submit(hung, 1, 1000.0);  // predicted 1 ms
  while (!hung.started) std::this_thread::yield();
  const double early = pool.predicted_wait_us();
  EXPECT_GE(early, 1000.0);
  EXPECT_LT(early, 50000.0);
  pool.submit(queued, 1, 500.0);
  EXPECT_EQ(pool.load().queued, 1u);
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  // 120 ms into a job predicted at 1 ms: it counts at >= 120 ms, plus the queued job's 0.5 ms
  const double late = pool.predicted_wait_us();
  EXPECT_GE(late, 120000.0 + 500.0);
  EXPECT_GE(pool.load().pending_us, late);
  EXPECT_EQ(pool.load().running, 1u);
  hung.release = true;
  queued.release = true;
  while (!queued.done) std::this_thread::yield();
  // give_back runs after the job: wait for the pool to settle
  for (int i = 0; i < 1000 && pool.load().running != 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_EQ(pool.load().pending_us, 0.0);
  EXPECT_EQ(pool.predicted_wait_us(), 0.0);
}

}  // namespace
}  // namespace rbdgrad::server
