// Benchmarks for plugins/cpu: one batch of N gradients (fd_derivatives, tau input, M^-1 computed,
// outputs d qdd/d q and d qdd/d qd in f64) through CpuInstance, on 1 and 2 persistent threads,
// next to the same states computed sequentially on the caller's thread with the core library;
// and small batches on 4, 8 and 16 threads (cpu_plugin_many), for many-core machines.
// Figures are microseconds per batch, comparable to the batch table of ../shared/anchors.md.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/model_desc.hpp"
#include "cpu_instance.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using rbdgrad::Model;

struct Batch {
  int nv = 0;
  std::size_t n = 0;
  std::vector<double> q, qd, tau, dq, dqd;
  std::vector<int32_t> status;
  rbdgrad_batch view{};
};

Model load(const std::string& robot) {
  Model m;
  if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, m).is_ok()) std::abort();
  return m;
}

std::unique_ptr<Batch> make_batch(const Model& m, std::size_t n) {
  auto b = std::make_unique<Batch>();
  b->nv = m.nv;
  b->n = n;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t v = n * static_cast<std::size_t>(m.nv), mat = v * static_cast<std::size_t>(m.nv);
  for (auto* x : {&b->q, &b->qd, &b->tau}) {
    x->resize(v);
    for (double& e : *x) e = u(rng);
  }
  for (double& e : b->q) e *= 2.5;
  for (double& e : b->tau) e *= 10;
  b->dq.resize(mat);
  b->dqd.resize(mat);
  b->status.resize(n);
  rbdgrad_batch& w = b->view;
  w.struct_size = sizeof(rbdgrad_batch);
  w.n = n;
  w.precision = RBDGRAD_PRECISION_F64;
  w.input_kind = RBDGRAD_INPUT_TAU;
  w.outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  w.q = b->q.data();
  w.qd = b->qd.data();
  w.u = b->tau.data();
  w.dqdd_dq = b->dq.data();
  w.dqdd_dqd = b->dqd.data();
  w.state_status = b->status.data();
  return b;
}

void plugin_batch(benchmark::State& state, std::string robot, std::size_t n, std::size_t threads) {
  const Model m = load(robot);
  std::unique_ptr<rbdgrad::plugin::CpuInstance> instance;
  if (!rbdgrad::plugin::CpuInstance::create(m, threads, instance).is_ok()) {
    state.SkipWithError("create failed");
    return;
  }
  auto b = make_batch(m, n);
  if (!instance->compute(&b->view).is_ok()) {
    state.SkipWithError("compute failed");
    return;
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(instance->compute(&b->view));
    benchmark::ClobberMemory();
  }
  state.counters["us_per_batch"] = benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void core_sequential(benchmark::State& state, std::string robot, std::size_t n) {
  const Model m = load(robot);
  rbdgrad::Workspace ws(m);
  auto b = make_batch(m, n);
  const auto nv = static_cast<Eigen::Index>(m.nv);
  for (auto _ : state) {
    for (std::size_t k = 0; k < n; ++k) {
      const auto off = static_cast<Eigen::Index>(k) * nv;
      benchmark::DoNotOptimize(rbdgrad::fd_derivatives(m, ws, Eigen::Map<const Eigen::VectorXd>(b->q.data() + off, nv),
                                                       Eigen::Map<const Eigen::VectorXd>(b->qd.data() + off, nv),
                                                       Eigen::Map<const Eigen::VectorXd>(b->tau.data() + off, nv),
                                                       rbdgrad::InputKind::kTau));
    }
    benchmark::ClobberMemory();
  }
}

const bool registered = [] {
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    for (std::size_t n : {1, 16, 128}) {
      const std::string suffix = std::string(robot) + "/N" + std::to_string(n);
      benchmark::RegisterBenchmark(("core_sequential/" + suffix).c_str(), core_sequential, robot, n)
          ->Unit(benchmark::kMicrosecond);
      for (std::size_t threads : {1, 2})
        benchmark::RegisterBenchmark(("cpu_plugin/" + suffix + "/threads" + std::to_string(threads)).c_str(),
                                     plugin_batch, robot, n, threads)
            ->Unit(benchmark::kMicrosecond);
    }
  }
  // small batches on many threads: the scheduler's calibration on a 16-core machine measured
  // 1.2 ms for 4 iiwa14 states against 32 us for 16 (docs/benchmarks/scheduler.md)
  for (std::size_t threads : {4, 8, 16})
    for (std::size_t n : {1, 2, 4, 8, 16, 64})
      benchmark::RegisterBenchmark(("cpu_plugin_many/iiwa14/N" + std::to_string(n) + "/threads" +
                                    std::to_string(threads)).c_str(),
                                   plugin_batch, "iiwa14", n, threads)
          ->Unit(benchmark::kMicrosecond);
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
