// Benchmark of the scenes' skips on the CUDA backend (issue 8): one synchronous CudaInstance::compute
// per batch, end to end (pinned host arrays in, pinned host arrays out) and the kernel alone (CUDA
// events, kernel_us), for the full computation and for each stage a scene can skip.
//
// Variants (full: d qdd/d q and d qdd/d qd from tau, M^-1 computed, gravity, forces on every body):
//   full, dq_only, dqd_only, cached_minv (M^-1 supplied with each state), no_fext (no forces),
//   no_gravity (the model's gravity zero), locked (talos_reduced with its head, grippers and wrists
//   locked: 22 joints; its "full" is the 32-joint robot).
// Each variant runs two ways:
//   per_batch: an instance without a plan: the kernel skips stages by the batch's outputs and
//              whether it brings M^-1 (per-request masks, no scene);
//   scene:     an instance made with the variant's plan (ABI 1.3), whose kernel is compiled by
//              NVRTC with the stages fixed: the build that never had the skipped stages.
// Names: "<robot>/<f64|f32>/<variant>/<per_batch|scene>/N<n>". Medians of 5 repetitions, µs per batch.
// Without a GPU every case is skipped with the reason.
#include <benchmark/benchmark.h>

#include <cuda_runtime_api.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "../../tests/support/test_models.hpp"
#include "common/batch_plan.hpp"
#include "cuda_instance.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using rbdgrad::Model;
using rbdgrad::Status;

constexpr std::uint32_t kDq = RBDGRAD_OUTPUT_DQDD_DQ, kDqd = RBDGRAD_OUTPUT_DQDD_DQD;

enum class Variant { kFull, kDqOnly, kDqdOnly, kCachedMinv, kNoFext, kNoGravity, kLocked };
const char* variant_name(Variant v) {
  switch (v) {
    case Variant::kFull: return "full";
    case Variant::kDqOnly: return "dq_only";
    case Variant::kDqdOnly: return "dqd_only";
    case Variant::kCachedMinv: return "cached_minv";
    case Variant::kNoFext: return "no_fext";
    case Variant::kNoGravity: return "no_gravity";
    case Variant::kLocked: return "locked";
  }
  return "?";
}
std::uint32_t outputs_of(Variant v) { return v == Variant::kDqOnly ? kDq : v == Variant::kDqdOnly ? kDqd : kDq | kDqd; }
bool has_fext(Variant v) { return v != Variant::kNoFext; }
bool has_minv(Variant v) { return v == Variant::kCachedMinv; }

Model load(const std::string& robot) {
  Model m;
  if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, m).is_ok()) std::abort();
  return m;
}

// the variant's model: gravity zero, or the humanoid with its hands and head locked
Model model_of(const std::string& robot, Variant v) {
  Model m = load(robot);
  if (v == Variant::kNoGravity) m.gravity.setZero();
  if (v == Variant::kLocked) {
    Model locked;
    if (!rbdgrad::lock_joints(m, rbdgrad::testing::talos_hands_and_head(m), locked).is_ok()) std::abort();
    return locked;
  }
  return m;
}

// One instance per (robot, variant, way), created and compiled once for all sizes.
struct Instances {
  std::map<std::string, std::unique_ptr<rbdgrad::cuda::CudaInstance>> made;
  std::string unavailable;

  rbdgrad::cuda::CudaInstance* get(const std::string& robot, Variant v, bool scene) {
    if (!unavailable.empty()) return nullptr;
    const std::string key = robot + "/" + variant_name(v) + (scene ? "/scene" : "/per_batch");
    auto& slot = made[key];
    if (slot) return slot.get();
    const Model model = model_of(robot, v);
    if (Status s = rbdgrad::cuda::CudaInstance::create(model, 0, slot); !s) {
      unavailable = s.to_string();
      return nullptr;
    }
    if (scene) {
      rbdgrad::plugin::BatchPlan plan;
      plan.outputs = outputs_of(v);
      plan.minv_supplied = has_minv(v);
      if (has_fext(v))
        for (int i = 0; i < model.nv; ++i) plan.fext_bodies.push_back(static_cast<std::uint32_t>(i));
      slot->set_plan(plan);
    }
    (void)slot->specialize("/tmp/rbdgrad-bench-kernels");
    std::fprintf(stderr, "%s: %s\n", key.c_str(), slot->kernel_description().c_str());
    return slot.get();
  }
};
Instances& instances() {
  static Instances i;
  return i;
}

// One batch in pinned host memory: random states, forces, M^-1(q) from the core where supplied.
template <class S>
struct Batch {
  std::vector<void*> pinned;
  rbdgrad_batch view{};
  bool ok = true;

  ~Batch() {
    for (void* p : pinned) cudaFreeHost(p);
  }
  S* alloc(std::size_t count) {
    void* p = nullptr;
    if (cudaMallocHost(&p, count * sizeof(S)) != cudaSuccess) {
      ok = false;
      return nullptr;
    }
    pinned.push_back(p);
    std::memset(p, 0, count * sizeof(S));
    return static_cast<S*>(p);
  }

  Batch(const Model& m, std::size_t n, Variant v) {
    const std::size_t nv = static_cast<std::size_t>(m.nv), vec = n * nv, mat = vec * nv;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> unit(-1, 1);
    S* q = alloc(vec);
    S* qd = alloc(vec);
    S* tau = alloc(vec);
    S* fext = has_fext(v) ? alloc(6 * vec) : nullptr;
    S* minv = has_minv(v) ? alloc(mat) : nullptr;
    view.struct_size = sizeof(rbdgrad_batch);
    view.n = n;
    view.precision = std::is_same_v<S, float> ? RBDGRAD_PRECISION_F32 : RBDGRAD_PRECISION_F64;
    view.input_kind = RBDGRAD_INPUT_TAU;
    view.outputs = outputs_of(v);
    view.dqdd_dq = view.outputs & kDq ? alloc(mat) : nullptr;
    view.dqdd_dqd = view.outputs & kDqd ? alloc(mat) : nullptr;
    view.state_status = reinterpret_cast<std::int32_t*>(alloc(n * 2));
    if (!ok) return;
    for (std::size_t e = 0; e < vec; ++e) {
      q[e] = static_cast<S>(unit(rng));
      qd[e] = static_cast<S>(unit(rng));
      tau[e] = static_cast<S>(unit(rng));
    }
    if (fext)
      for (std::size_t e = 0; e < 6 * vec; ++e) fext[e] = static_cast<S>(2 * unit(rng));
    if (minv) {
      rbdgrad::Workspace ws(m);
      for (std::size_t k = 0; k < n; ++k) {
        Eigen::VectorXd qk(m.nv);
        for (std::size_t i = 0; i < nv; ++i) qk(static_cast<Eigen::Index>(i)) = static_cast<double>(q[k * nv + i]);
        if (!rbdgrad::minverse(m, ws, qk)) std::abort();
        for (std::size_t i = 0; i < nv; ++i)
          for (std::size_t j = 0; j < nv; ++j)
            minv[k * nv * nv + i * nv + j] =
                static_cast<S>(ws.Minv(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)));
      }
    }
    view.q = q;
    view.qd = qd;
    view.u = tau;
    view.fext = fext;
    view.minv = minv;
  }
};

template <class S>
void scene_e2e(benchmark::State& state, std::string robot, Variant v, bool scene, std::size_t n) {
  rbdgrad::cuda::CudaInstance* instance = instances().get(robot, v, scene);
  if (instance == nullptr) {
    state.SkipWithError(("CUDA backend unavailable: " + instances().unavailable).c_str());
    return;
  }
  Batch<S> b(model_of(robot, v), n, v);
  if (!b.ok) {
    state.SkipWithError("cudaMallocHost failed");
    return;
  }
  rbdgrad::cuda::KernelOptions options = instance->kernel_options();
  options.time_kernel = false;
  (void)instance->set_kernel_options(options);
  if (Status s = instance->compute(&b.view); !s) {  // sizes the buffers: not the steady state
    state.SkipWithError(s.to_string().c_str());
    return;
  }
  for (auto _ : state) {
    if (Status s = instance->compute(&b.view); !s) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    benchmark::ClobberMemory();
  }
  options.time_kernel = true;
  (void)instance->set_kernel_options(options);
  double kernel_ms = 0;
  const int timed = 50;
  for (int k = 0; k < timed; ++k) {
    if (Status s = instance->compute(&b.view); !s) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    kernel_ms += instance->last_kernel_ms();
  }
  options.time_kernel = false;
  (void)instance->set_kernel_options(options);
  state.counters["kernel_us"] = 1e3 * kernel_ms / timed;
  state.counters["block_kernel"] = instance->last_used_block_kernel() ? 1 : 0;
  state.counters["robot_specific"] = instance->last_used_robot_specific_kernel() ? 1 : 0;
}

const bool registered = [] {
  const Variant variants[] = {Variant::kFull,   Variant::kDqOnly,    Variant::kDqdOnly, Variant::kCachedMinv,
                              Variant::kNoFext, Variant::kNoGravity, Variant::kLocked};
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (const bool f32 : {false, true})
      for (const Variant v : variants) {
        if (v == Variant::kLocked && std::string(robot) != "talos_reduced") continue;
        for (const bool scene : {false, true}) {
          if (v == Variant::kFull && scene) continue;
          for (const std::size_t n : {16, 1024, 16384}) {
            const std::string name = std::string(robot) + (f32 ? "/f32/" : "/f64/") + variant_name(v) +
                                     (scene ? "/scene" : "/per_batch") + "/N" + std::to_string(n);
            auto* b = f32 ? benchmark::RegisterBenchmark(name.c_str(), scene_e2e<float>, robot, v, scene, n)
                          : benchmark::RegisterBenchmark(name.c_str(), scene_e2e<double>, robot, v, scene, n);
            b->Unit(benchmark::kMicrosecond)->UseRealTime()->Repetitions(5)->ReportAggregatesOnly(true);
          }
        }
      }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
