// Tests for server/scheduler.cpp and server/calibration.cpp with three fake backends of known
// latency (fakes/fake_timed.cpp): "fpga" (Q16.16, its own model: 10 us + 10 us/state), "cpu"
// (sleeps 300 us + 2 us/state) and "cuda" (sleeps 3000 us + 0.1 us/state). With exact sleeps the
// models cross at N = 36 (fpga -> cpu) and N = 1420 (cpu -> cuda); a sleep overshoots by tens of
// microseconds, which moves the first to about 50. Every routing decision below is far from both,
// so that timer noise on a loaded machine cannot flip it.
#include "scheduler.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;

struct Fixture {
  ModelRegistry models;
  std::unique_ptr<BackendPool> backends;

  explicit Fixture(const std::string& cpu_fixed_us = "300", const std::string& cuda_per_state_us = "0.1") {
    EXPECT_TRUE(ModelRegistry::load({{"iiwa14", "", "iiwa14", std::nullopt}}, models));
    BackendPool::Options o;
    o.cpu_plugin_path = "";  // the fakes only
    o.plugins = {{FAKE_TIMED_FPGA_PATH, {{"fixed_us", "10"}, {"per_state_us", "10"}}},
                 {FAKE_TIMED_CPU_PATH, {{"fixed_us", cpu_fixed_us}, {"per_state_us", "2"}}},
                 {FAKE_TIMED_CUDA_PATH, {{"fixed_us", "3000"}, {"per_state_us", cuda_per_state_us}}}};
    backends = BackendPool::create(o, models);
    EXPECT_EQ(backends->ready_count(), 3u);
  }
  const ServedModel& iiwa() const { return *models.models().front(); }
};

SchedulerConfig config(const std::string& policy = "cost", const std::string& file = "") {
  SchedulerConfig c;
  c.policy = policy;
  c.calibration_file = file;
  c.calibration_sizes = {1, 16, 256, 4096};
  return c;
}

std::vector<std::string> calibrate(Scheduler& s, bool remeasure = false) {
  std::vector<std::string> log;
  s.calibrate(remeasure, [&](const std::string& line) { log.push_back(line); });
  return log;
}

std::string route(const Scheduler& s, const ServedModel& m, std::uint64_t n, std::uint32_t precision = 0,
                  std::string_view hint = "") {
  Route r;
  double predicted = 0;
  const Status st = s.route(m, {hint, precision, RBDGRAD_OUTPUT_DQDD_DQ, n}, r, predicted);
  EXPECT_TRUE(st.is_ok()) << st.message();
  return st ? r.backend->name : st.message();
}

struct TempFile {
  std::string path = (std::filesystem::temp_directory_path() /
                      ("rbdgrad-calibration-" + std::to_string(::getpid()) + "-" +
                       std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) + ".yaml"))
                         .string();
  ~TempFile() { std::filesystem::remove(path); }
};

TEST(Scheduler, CalibrationMeasuresWhatHasNoModelOfItsOwn) {
  Fixture f;
  Scheduler s(*f.backends, f.models, config());
  const std::vector<std::string> log = calibrate(s);
  const CalibrationTable t = s.table();
  // fpga: its own model, fixed only; cpu and cuda measured in f64 and f32
  ASSERT_EQ(t.entries().size(), 5u);
  const CalibrationEntry* fpga = t.find("fpga", "iiwa14", RBDGRAD_PRECISION_FIXED_Q16_16);
  ASSERT_NE(fpga, nullptr);
  EXPECT_EQ(fpga->source, "the plugin's own model (estimate_latency)");
  EXPECT_DOUBLE_EQ(fpga->latency.predict_us(16), 170);
  const CalibrationEntry* cpu = t.find("cpu", "iiwa14", RBDGRAD_PRECISION_F64);
  ASSERT_NE(cpu, nullptr);
  EXPECT_THAT(cpu->source, HasSubstr("measured 20"));
  // a sleep lasts at least as long as asked
  EXPECT_GE(cpu->latency.predict_us(1), 302);
  EXPECT_GE(cpu->latency.predict_us(4096), 300 + 2 * 4096);
  EXPECT_LT(cpu->latency.predict_us(4096), 3 * (300 + 2 * 4096));
  EXPECT_NE(t.find("cuda", "iiwa14", RBDGRAD_PRECISION_F32), nullptr);
  EXPECT_EQ(log.size(), 5u);
  EXPECT_THAT(log[0],
              HasSubstr("calibration: fpga iiwa14 fixed: 20 us at N = 1, 4.097e+04 us at N = 4096, then 10 us/state"));
}

TEST(Scheduler, CostPolicyRoutesSmallToFpgaMiddleToCpuLargeToCuda) {
  Fixture f;
  Scheduler s(*f.backends, f.models, config());
  calibrate(s);
  EXPECT_EQ(route(s, f.iiwa(), 1), "fpga");
  EXPECT_EQ(route(s, f.iiwa(), 4), "fpga");
  EXPECT_EQ(route(s, f.iiwa(), 200), "cpu");
  EXPECT_EQ(route(s, f.iiwa(), 20000), "cuda");
  // the crossovers as GetServerInfo shows them
  const auto c = s.crossovers(f.iiwa(), 0, 1 << 20);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0], (std::pair<std::uint64_t, std::string>{1, "fpga"}));
  EXPECT_EQ(c[1].second, "cpu");
  // 36 and 1420 with exact sleeps; a sleep overshoots by tens of us, more on a loaded machine
  EXPECT_GE(c[1].first, 20u);
  EXPECT_LE(c[1].first, 150u);
  EXPECT_EQ(c[2].second, "cuda");
  EXPECT_GE(c[2].first, 600u);
  EXPECT_LE(c[2].first, 4000u);
}

TEST(Scheduler, ExplicitPrecisionIsKeptAndHintsPin) {
  Fixture f;
  Scheduler s(*f.backends, f.models, config());
  calibrate(s);
  // f64 never lands on the fixed-point fpga
  EXPECT_EQ(route(s, f.iiwa(), 1, RBDGRAD_PRECISION_F64), "cpu");
  EXPECT_EQ(route(s, f.iiwa(), 20000, RBDGRAD_PRECISION_F32), "cuda");
  EXPECT_EQ(route(s, f.iiwa(), 1, RBDGRAD_PRECISION_FIXED_Q16_16), "fpga");
  // a hint pins the backend whatever the models say
  EXPECT_EQ(route(s, f.iiwa(), 1, 0, "cuda"), "cuda");
  EXPECT_EQ(route(s, f.iiwa(), 20000, 0, "cpu"), "cpu");
  // the prediction of the chosen backend comes back with the route
  Route r;
  double predicted = 0;
  ASSERT_TRUE(s.route(f.iiwa(), {"", 0, RBDGRAD_OUTPUT_DQDD_DQ, 16}, r, predicted));
  EXPECT_EQ(r.precision, RBDGRAD_PRECISION_FIXED_Q16_16);
  EXPECT_DOUBLE_EQ(predicted, 170);
}

TEST(Scheduler, ThresholdPolicyConfiguredAndDerived) {
  Fixture f;
  SchedulerConfig c = config("threshold");
  c.small_n = 5;
  c.large_n = 50;
  Scheduler s(*f.backends, f.models, c);
  calibrate(s);
  EXPECT_EQ(route(s, f.iiwa(), 5), "fpga");
  EXPECT_EQ(route(s, f.iiwa(), 6), "cpu");
  EXPECT_EQ(route(s, f.iiwa(), 49), "cpu");
  EXPECT_EQ(route(s, f.iiwa(), 50), "cuda");
  // from the crossovers when not configured
  Scheduler derived(*f.backends, f.models, config("threshold"));
  calibrate(derived);
  const auto [small_n, large_n] = derived.thresholds(f.iiwa());
  EXPECT_GE(small_n, 19);
  EXPECT_LE(small_n, 79);
  EXPECT_GE(large_n, 600);
  EXPECT_EQ(route(derived, f.iiwa(), 4), "fpga");
  EXPECT_EQ(route(derived, f.iiwa(), 200), "cpu");
  EXPECT_EQ(route(derived, f.iiwa(), 20000), "cuda");
}

// A job that holds a backend's only instance until released.
class HoldingJob : public PoolJob {
 public:
  void run(PluginInstance&) noexcept override {
    std::unique_lock lock(mutex_);
    started_ = true;
    changed_.notify_all();
    changed_.wait(lock, [&] { return released_; });
  }
  void wait_started() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return started_; });
  }
  void release() {
    std::lock_guard lock(mutex_);
    released_ = true;
    changed_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool started_ = false, released_ = false;
};

TEST(Scheduler, QueuedWorkCountsInTheCost) {
  Fixture f;
  Scheduler s(*f.backends, f.models, config());
  calibrate(s);
  EXPECT_EQ(route(s, f.iiwa(), 200), "cpu");
  // the cpu busy with 100 ms of predicted work: 200 states go to the fpga (2 ms) instead
  InstancePool* cpu = f.backends->pool("cpu", f.iiwa());
  ASSERT_NE(cpu, nullptr);
  HoldingJob job;
  std::thread submitter([&] { cpu->submit(job, 1, 100000); });
  job.wait_started();
  EXPECT_EQ(cpu->load().running, 1u);
  EXPECT_DOUBLE_EQ(cpu->load().pending_us, 100000);
  EXPECT_EQ(route(s, f.iiwa(), 200), "fpga");
  const std::vector<Prediction> p = s.predictions(f.iiwa(), {"", 0, RBDGRAD_OUTPUT_DQDD_DQ, 200});
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[1].backend, "cpu");
  EXPECT_DOUBLE_EQ(p[1].wait_us, 100000);
  job.release();
  submitter.join();
  // the pool gives the work back once it has run
  for (int i = 0; i < 200 && cpu->load().pending_us > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(cpu->load().pending_us, 0);
  EXPECT_EQ(route(s, f.iiwa(), 200), "cpu");
}

// cpu 300 us + 2 us/state, cuda 3000 us + 1 us/state: 8192 states take cuda 11.2 ms alone, and
// about 7.6 ms split (cpu 3630, cuda 4562 states, finishing together).
TEST(Scheduler, SplitsALargeRequestWhenTheModelsPredictAGain) {
  Fixture f("300", "1");
  SchedulerConfig c = config();
  c.split_min_states = 4096;
  Scheduler s(*f.backends, f.models, c);
  calibrate(s);
  const RouteQuery query{"", RBDGRAD_PRECISION_F64, RBDGRAD_OUTPUT_DQDD_DQ, 8192};
  Route alone;
  double compute_us = 0, wait_us = 0;
  ASSERT_TRUE(s.route(f.iiwa(), query, alone, compute_us, &wait_us));
  EXPECT_EQ(alone.backend->name, "cuda");
  const std::vector<SplitPart> parts = s.split(f.iiwa(), query, alone.precision, wait_us + compute_us);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].route.backend->name, "cpu");  // load order: fpga (not f64), cpu, cuda
  EXPECT_EQ(parts[1].route.backend->name, "cuda");
  EXPECT_EQ(parts[0].route.precision, RBDGRAD_PRECISION_F64);
  EXPECT_EQ(parts[1].route.precision, RBDGRAD_PRECISION_F64);
  EXPECT_EQ(parts[0].first, 0u);
  EXPECT_EQ(parts[1].first, parts[0].n);
  EXPECT_EQ(parts[0].n + parts[1].n, 8192u);
  EXPECT_GT(parts[0].n, 3000u);  // 3630 with exact sleeps
  EXPECT_LT(parts[0].n, 4200u);
  for (const SplitPart& p : parts) {
    EXPECT_LE(p.wait_us + p.compute_us, 0.9 * (wait_us + compute_us));
    EXPECT_EQ(p.route.pool, f.backends->pool(p.route.backend->name, f.iiwa()));
  }
  // the 10% rule: the same shares are refused when they would finish less than 10% before the
  // request alone (deterministic: the split depends only on the models and the idle queues)
  double makespan = 0;
  for (const SplitPart& p : parts) makespan = std::max(makespan, p.wait_us + p.compute_us);
  EXPECT_TRUE(s.split(f.iiwa(), query, alone.precision, 0.99 * makespan / 0.9).empty());
  EXPECT_EQ(s.split(f.iiwa(), query, alone.precision, 1.01 * makespan / 0.9).size(), 2u);
  // not split: below split_min_states, pinned, fixed point (the fpga alone has it), or by the
  // threshold policy
  EXPECT_TRUE(s.split(f.iiwa(), {"", RBDGRAD_PRECISION_F64, RBDGRAD_OUTPUT_DQDD_DQ, 4095}, alone.precision, 1e9).empty());
  EXPECT_TRUE(s.split(f.iiwa(), {"cuda", RBDGRAD_PRECISION_F64, RBDGRAD_OUTPUT_DQDD_DQ, 8192}, alone.precision,
                      wait_us + compute_us)
                  .empty());
  EXPECT_TRUE(s.split(f.iiwa(), {"", 0, RBDGRAD_OUTPUT_DQDD_DQ, 8192}, RBDGRAD_PRECISION_FIXED_Q16_16, 1e9).empty());
  c.policy = "threshold";
  Scheduler s3(*f.backends, f.models, c);
  calibrate(s3);
  EXPECT_TRUE(s3.split(f.iiwa(), query, RBDGRAD_PRECISION_F64, 1e9).empty());
}

TEST(Scheduler, WithoutModelsTheCpuTakesEverything) {
  Fixture f;
  SchedulerConfig c = config();
  c.calibrate = "off";
  Scheduler s(*f.backends, f.models, c);
  calibrate(s);
  // the fpga's own model still counts: without the others it wins everything it can run
  EXPECT_EQ(route(s, f.iiwa(), 20000), "fpga");
  // f64: no backend with a model can take it, BackendPool's rule picks the cpu
  EXPECT_EQ(route(s, f.iiwa(), 1, RBDGRAD_PRECISION_F64), "cpu");
  EXPECT_EQ(s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64), nullptr);
  // an explicit calibration (the Calibrate RPC) measures all the same
  calibrate(s, true);
  EXPECT_NE(s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64), nullptr);
  EXPECT_EQ(route(s, f.iiwa(), 20000), "cuda");
}

TEST(Scheduler, CalibrationFileIsReusedWhileTheFingerprintHolds) {
  TempFile file;
  std::string cpu_source;
  {
    Fixture f;
    Scheduler s(*f.backends, f.models, config("cost", file.path));
    calibrate(s);
    ASSERT_TRUE(std::filesystem::exists(file.path));
    cpu_source = s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->source;
  }
  {
    // same backends and model: nothing measured again, the file's models come back as they were
    Fixture f;
    Scheduler s(*f.backends, f.models, config("cost", file.path));
    const auto t0 = std::chrono::steady_clock::now();
    calibrate(s);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500)) << "it measured again";
    EXPECT_EQ(s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->source, cpu_source);
    EXPECT_EQ(route(s, f.iiwa(), 200), "cpu");
    // on demand: measured anew
    calibrate(s, true);
    EXPECT_NE(s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->source, "");
  }
  {
    // the cpu backend's options changed: its models are stale and measured again
    Fixture f("400");
    Scheduler s(*f.backends, f.models, config("cost", file.path));
    calibrate(s);
    EXPECT_GE(s.table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->latency.predict_us(1), 400);
  }
}

TEST(CalibrationTable, SavesAndLoadsAndRefusesOtherFiles) {
  TempFile file;
  CalibrationTable t;
  t.set({"cuda", "iiwa14", RBDGRAD_PRECISION_F32, "abc-def", "measured 2026-12-02T08:00:00Z",
         LatencyModel({{1, 25.5}, {1024, 80.25}})});
  ASSERT_TRUE(t.save(file.path));
  CalibrationTable back;
  ASSERT_TRUE(CalibrationTable::load(file.path, back));
  ASSERT_EQ(back.entries().size(), 1u);
  const CalibrationEntry& e = back.entries()[0];
  EXPECT_EQ(e.backend, "cuda");
  EXPECT_EQ(e.precision, RBDGRAD_PRECISION_F32);
  EXPECT_EQ(e.fingerprint, "abc-def");
  EXPECT_EQ(e.latency.points(), t.entries()[0].latency.points());
  EXPECT_EQ(CalibrationTable::load(file.path + ".missing", back).code(), StatusCode::kNotFound);
  std::ofstream(file.path) << "listen: {tcp: x}\n";
  const Status s = CalibrationTable::load(file.path, back);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("not an rbdgrad calibration file"));
  std::ofstream(file.path) << "rbdgrad_calibration: 1\nentries:\n  - {backend: cpu, model: m, precision: f16, points: []}\n";
  EXPECT_THAT(CalibrationTable::load(file.path, back).message(), HasSubstr("unknown precision 'f16'"));
}

}  // namespace
}  // namespace rbdgrad::server
