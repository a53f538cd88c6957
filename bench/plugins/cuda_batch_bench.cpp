// Benchmark for plugins/cuda, end to end as ../shared/anchors.md measures GRiD: host input buffers
// in, host output buffers out, around one synchronous CudaInstance::compute (what the plugin's
// compute entry point calls), plus the kernel's own time from CUDA events (kernel_us). The
// workload is the anchors' one: the forward-dynamics gradient from tau (M^-1 computed on the GPU),
// outputs d qdd/d q and d qdd/d qd, random states; iiwa14 and the humanoid (talos_reduced), f32
// and f64, N from 16 to 65536. Reported: the median of the repetitions, in microseconds per batch
// (real time). Without a GPU every case is skipped with the reason.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cuda_instance.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using rbdgrad::Model;
using rbdgrad::Status;

Model load(const std::string& robot) {
  Model m;
  if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, m).is_ok()) std::abort();
  return m;
}

// Inputs and outputs of one batch in the precision's scalar type, host memory the caller owns.
template <class S>
struct Batch {
  std::vector<S> q, qd, tau, dq, dqd;
  std::vector<int32_t> status;
  rbdgrad_batch view{};

  Batch(int nv, std::size_t n, std::uint32_t precision) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    const std::size_t v = n * static_cast<std::size_t>(nv), mat = v * static_cast<std::size_t>(nv);
    for (auto* x : {&q, &qd, &tau}) {
      x->resize(v);
      for (S& e : *x) e = static_cast<S>(u(rng));
    }
    dq.resize(mat);
    dqd.resize(mat);
    status.resize(n);
    view.struct_size = sizeof(rbdgrad_batch);
    view.n = n;
    view.precision = precision;
    view.input_kind = RBDGRAD_INPUT_TAU;
    view.outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
    view.q = q.data();
    view.qd = qd.data();
    view.u = tau.data();
    view.dqdd_dq = dq.data();
    view.dqdd_dqd = dqd.data();
    view.state_status = status.data();
  }
};

// One instance per robot, created once for all cases; the reason when none can be.
struct Backend {
  std::map<std::string, std::unique_ptr<rbdgrad::cuda::CudaInstance>> instances;
  std::string unavailable;

  rbdgrad::cuda::CudaInstance* instance(const std::string& robot) {
    if (!unavailable.empty()) return nullptr;
    auto& slot = instances[robot];
    if (!slot) {
      if (Status s = rbdgrad::cuda::CudaInstance::create(load(robot), 0, slot); !s) {
        unavailable = s.to_string();
        return nullptr;
      }
    }
    return slot.get();
  }
};

Backend& backend() {
  static Backend b;
  return b;
}

template <class S>
void cuda_e2e(benchmark::State& state, std::string robot, std::size_t n, std::uint32_t precision) {
  rbdgrad::cuda::CudaInstance* instance = backend().instance(robot);
  if (instance == nullptr) {
    state.SkipWithError(("CUDA backend unavailable: " + backend().unavailable).c_str());
    return;
  }
  Batch<S> b(load(robot).nv, n, precision);
  // the first call sizes the device and pinned buffers: not part of the steady state
  if (Status s = instance->compute(&b.view); !s) {
    state.SkipWithError(s.to_string().c_str());
    return;
  }
  double kernel_ms = 0;
  for (auto _ : state) {
    if (Status s = instance->compute(&b.view); !s) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    kernel_ms += instance->last_kernel_ms();
    benchmark::ClobberMemory();
  }
  state.counters["kernel_us"] = 1e3 * kernel_ms / static_cast<double>(state.iterations());
  state.counters["states_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n), benchmark::Counter::kIsRate);
}

const bool registered = [] {
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    for (std::size_t n : {16, 32, 64, 128, 256, 1024, 4096, 16384, 65536}) {
      const std::string suffix = std::string(robot) + "/N" + std::to_string(n);
      benchmark::RegisterBenchmark(("cuda_e2e/f32/" + suffix).c_str(), cuda_e2e<float>, robot, n,
                                   RBDGRAD_PRECISION_F32)
          ->Unit(benchmark::kMicrosecond)->UseRealTime()->Repetitions(5)->ReportAggregatesOnly(true);
      benchmark::RegisterBenchmark(("cuda_e2e/f64/" + suffix).c_str(), cuda_e2e<double>, robot, n,
                                   RBDGRAD_PRECISION_F64)
          ->Unit(benchmark::kMicrosecond)->UseRealTime()->Repetitions(5)->ReportAggregatesOnly(true);
    }
  }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
