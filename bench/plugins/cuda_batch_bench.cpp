// Benchmark for plugins/cuda, end to end as ../shared/anchors.md measures GRiD: host input buffers
// in, host output buffers out, around one synchronous CudaInstance::compute (what the plugin's
// compute entry point calls), plus the kernel's own time from CUDA events (kernel_us). The
// workload is the anchors' one: the forward-dynamics gradient from tau (M^-1 computed on the GPU),
// outputs d qdd/d q and d qdd/d qd, random states; iiwa14 and the humanoid (talos_reduced), f32
// and f64, N from 16 to 65536. Reported: the median of the repetitions, in microseconds per batch
// (real time). Without a GPU every case is skipped with the reason.
#include <benchmark/benchmark.h>

#include <cuda_runtime_api.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <map>
#include <mutex>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
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

// Inputs and outputs of one batch in the precision's scalar type, host memory the caller owns:
// ordinary (pageable) memory, or pinned (cudaMallocHost) as the anchors' pinned columns have it.
template <class S>
struct Batch {
  std::vector<S> q, qd, tau, dq, dqd;
  std::vector<int32_t> status;
  std::vector<void*> pinned;
  rbdgrad_batch view{};

  ~Batch() {
    for (void* p : pinned) cudaFreeHost(p);
  }
  Batch(const Batch&) = delete;
  Batch& operator=(const Batch&) = delete;

  // a pinned copy of x (nullptr if the allocation fails)
  S* pin(const std::vector<S>& x) {
    void* p = nullptr;
    if (cudaMallocHost(&p, x.size() * sizeof(S)) != cudaSuccess) return nullptr;
    std::memcpy(p, x.data(), x.size() * sizeof(S));
    pinned.push_back(p);
    return static_cast<S*>(p);
  }

  Batch(int nv, std::size_t n, std::uint32_t precision, bool pinned_memory) {
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
    if (pinned_memory) {
      view.q = pin(q);
      view.qd = pin(qd);
      view.u = pin(tau);
      view.dqdd_dq = pin(dq);
      view.dqdd_dqd = pin(dqd);
    }
  }
};

// One instance per robot, created once for all cases; the reason when none can be.
struct Backend {
  std::map<std::string, std::unique_ptr<rbdgrad::cuda::CudaInstance>> instances;  // robot#copy[#build]
  std::string unavailable;
  std::mutex mutex;  // benchmark threads create their own instances

  // build: the options that take effect when the kernels are compiled (block_compact, block_lean,
  // block_tree_chains, block_tree_columns and the block shape, which sets the compact kernel's
  // register cap): an instance of its own for each
  rbdgrad::cuda::CudaInstance* instance(const std::string& robot, int copy = 0,
                                        const rbdgrad::cuda::KernelOptions& build = {}) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!unavailable.empty()) return nullptr;
    std::string key = robot + "#" + std::to_string(copy);
    if (!build.block_compact) key += "#dense";
    if (build.block_lean) key += "#lean";
    if (build.block_tree_chains) key += "#chains";
    if (build.block_tree_columns) key += "#columns";
    // two appends: GCC 12 warns falsely (-Wrestrict) on "#" + std::to_string(...)
    key += '#';
    key += std::to_string(build.block_shape.threads_per_state);
    auto& slot = instances[key];
    if (!slot) {
      if (Status s = rbdgrad::cuda::CudaInstance::create(load(robot), 0, slot); !s) {
        unavailable = s.to_string();
        return nullptr;
      }
      rbdgrad::cuda::KernelOptions options;
      options.block_compact = build.block_compact;
      options.block_lean = build.block_lean;
      options.block_tree_chains = build.block_tree_chains;
      options.block_tree_columns = build.block_tree_columns;
      options.block_shape = build.block_shape;
      (void)slot->set_kernel_options(options);
      // as the plugin does by default: the block and warp kernels compiled for the robot (the
      // "generic" entries turn them off)
      (void)slot->specialize("");
      if (copy == 0) std::fprintf(stderr, "%s: %s\n", robot.c_str(), slot->kernel_description().c_str());
    }
    return slot.get();
  }
};

Backend& backend() {
  static Backend b;
  return b;
}

// A kernel choice: the one-thread kernel, or the block kernel in one shape.
struct Kernel {
  std::string name;
  rbdgrad::cuda::KernelOptions options;
};
Kernel thread_kernel() {
  Kernel k{"thread", {}};
  k.options.block_max_states = 0;
  return k;
}
// the plugin's defaults: the kernel, its shape and the I/O chosen by batch and model, the block
// kernel compiled for the robot
Kernel default_kernel() { return {"default", {}}; }
// the defaults with CUDA events around every kernel (the benchmarks' kernel time), which cost
// the end-to-end time two runtime calls: the price of timing
Kernel timed_kernel() {
  Kernel k{"timed", {}};
  k.options.time_kernel = true;
  return k;
}
// the same with the block and warp kernels compiled for any robot (the plugin's option
// specialize: false)
Kernel generic_kernel() {
  Kernel k{"generic", {}};
  k.options.robot_specific = false;
  return k;
}
// the block kernel at every size, in its default shape and I/O or with copies at every size
Kernel block_kernel(bool mapped_io) {
  Kernel k{mapped_io ? "block" : "block-copy", {}};
  k.options.f32_thread_kernel_min_states = 0;
  if (!mapped_io) k.options.mapped_io_max_kib = k.options.mapped_pinned_max_kib = 0;
  return k;
}
// the defaults with f32 batches computed in f32 arithmetic (the plugin's option f32_compute: f32;
// the default computes them in f64 on GPUs whose f64 is fast)
Kernel f32_arithmetic() {
  Kernel k{"f32-arith", {}};
  k.options.f32_compute = rbdgrad::cuda::F32Compute::kF32;
  return k;
}
// the defaults with every batch on mapped memory (no device copies; a pinned caller's arrays are
// the kernel's own inputs and outputs)
// the defaults without CUDA Graphs (every launch a stream call)
Kernel no_graphs() {
  Kernel k{"nograph", {}};
  k.options.graphs = false;
  return k;
}
// the defaults without the warp kernel: gradient batches on the block kernel, as before it
Kernel no_warp() {
  Kernel k{"nowarp", {}};
  k.options.warp_kernel = false;
  return k;
}
Kernel mapped_io() {
  Kernel k{"mapped", {}};
  k.options.mapped_io_max_kib = std::size_t{1} << 30;
  return k;
}
// the defaults with batches beyond one chunk in `chunks` chunks of any size (1: no pipeline)
Kernel pipeline(std::size_t chunks, bool robot_specific = true) {
  Kernel k{std::to_string(chunks) + "chunks" + (robot_specific ? "" : "-generic"), {}};
  k.options.chunks = {1, chunks};
  k.options.mapped_pinned_max_kib = 0;  // copies at every size measured
  k.options.robot_specific = robot_specific;
  return k;
}
// `k` with the block kernel at `threads` per state (one state a block)
Kernel wider(Kernel k, int threads) {
  // two appends: GCC 12 warns falsely (-Wrestrict) on "-" + std::to_string(...)
  k.name += '-';
  k.name += std::to_string(threads);
  k.options.block_shape = {threads, 1};
  return k;
}
// `k` with the dense block kernel (plugin option block_compact: false; the compact one, the
// default, fits more states an SM)
Kernel dense(Kernel k) {
  k.name += "-dense";
  k.options.block_compact = false;
  k.options.block_lean = false;
  return k;
}
// `k` with the compact kernel's full working set (plugin option block_lean: false; the lean one,
// the default, fits more states an SM still)
Kernel full(Kernel k) {
  k.name += "-full";
  k.options.block_lean = false;
  return k;
}
// the defaults with the warp kernel's first outputs written early (before d tau/d q) or late
Kernel warp_outputs(bool early) {
  Kernel k{early ? "early" : "late", {}};
  k.options.warp_early_outputs_min_bytes = early ? 0 : ~std::uint64_t{0};
  return k;
}
// `k` with the lean kernel's M^-1 columns a thread a column walking the tree (plugin option
// block_tree_columns: false; the default takes them by the tree's blocks)
Kernel walked_columns(Kernel k) {
  k.name += "-walkcolumns";
  k.options.block_tree_columns = false;
  return k;
}
// the defaults with a small batch's inputs in the warp kernel's parameters, in the smallest block
// that holds them (min_block 0) or one of at least min_block bytes, or (off) from host memory
Kernel warp_inputs(bool in_parameters, std::size_t min_block = 0) {
  Kernel k{in_parameters ? "params" + (min_block ? std::to_string(min_block) : std::string()) : "hostmem", {}};
  k.options.warp_inline_inputs = in_parameters;
  k.options.warp_inline_min_block = min_block;
  return k;
}
// the defaults checking from `bytes` of inputs and outputs whether the caller's arrays are pinned
Kernel pinned_check(std::size_t bytes) {
  Kernel k{"check" + std::to_string(bytes), {}};
  k.options.pinned_check_min_bytes = bytes;
  return k;
}
Kernel block_kernel(int threads_per_state, int states_per_block) {
  Kernel k{"block" + std::to_string(threads_per_state) + "x" + std::to_string(states_per_block), {}};
  k.options.block_shape = {threads_per_state, states_per_block};
  return k;
}

// Each benchmark thread (cuda_concurrent) runs its own instance, as the daemon's instance pool
// does with a plugin entry's `instances`.
template <class S>
void cuda_e2e(benchmark::State& state, std::string robot, std::size_t n, std::uint32_t precision, Kernel kernel,
              bool pinned_memory) {
  rbdgrad::cuda::CudaInstance* instance =
      backend().instance(robot, state.thread_index(), kernel.options);
  if (instance == nullptr) {
    state.SkipWithError(("CUDA backend unavailable: " + backend().unavailable).c_str());
    return;
  }
  if (Status s = instance->set_kernel_options(kernel.options); !s) {
    state.SkipWithError(s.to_string().c_str());
    return;
  }
  Batch<S> b(load(robot).nv, n, precision, pinned_memory);
  if (pinned_memory && (!b.view.q || !b.view.dqdd_dqd)) {
    state.SkipWithError("cudaMallocHost failed");
    return;
  }
  // the first call sizes the device and pinned buffers: not part of the steady state
  if (Status s = instance->compute(&b.view); !s) {
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
  const bool graph_used = instance->last_used_graph();  // before the timed calls, which never use one
  // the kernel alone, from CUDA events, in calls of their own: the events cost the end-to-end
  // time two runtime calls, which the plugin makes only when asked (time_kernel)
  rbdgrad::cuda::KernelOptions timed = kernel.options;
  timed.time_kernel = true;
  (void)instance->set_kernel_options(timed);
  const int timed_calls = static_cast<int>(std::min<benchmark::IterationCount>(state.iterations(), 100));
  double kernel_ms = 0;
  for (int k = 0; k < timed_calls; ++k) {
    if (Status s = instance->compute(&b.view); !s) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    kernel_ms += instance->last_kernel_ms();
  }
  (void)instance->set_kernel_options(kernel.options);
  state.counters["kernel_us"] = 1e3 * kernel_ms / timed_calls;
  state.counters["block_kernel"] = instance->last_used_block_kernel() ? 1 : 0;
  state.counters["warp_kernel"] = instance->last_used_warp_kernel() ? 1 : 0;
  state.counters["inline_block"] = static_cast<double>(instance->last_inline_block_bytes());
  state.counters["robot_specific"] = instance->last_used_robot_specific_kernel() ? 1 : 0;
  state.counters["f32_in_f64"] = instance->last_computed_f32_in_f64() ? 1 : 0;
  state.counters["chunks"] = static_cast<double>(instance->last_chunks());
  state.counters["graph"] = graph_used ? 1 : 0;
  state.counters["mapped_io"] = instance->last_used_mapped_io() ? 1 : 0;
  state.counters["pinned_arrays"] = instance->last_pinned_arrays();
  state.counters["states_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n), benchmark::Counter::kIsRate);
}

template <class S>
void add(const std::string& family, const std::string& robot, std::size_t n, const Kernel& kernel,
         bool pinned_memory = true) {
  constexpr bool f32 = std::is_same_v<S, float>;
  const std::string name = family + "/" + kernel.name + (pinned_memory ? "/pinned" : "/pageable") +
                           (f32 ? "/f32/" : "/f64/") + robot + "/N" + std::to_string(n);
  benchmark::RegisterBenchmark(name.c_str(), cuda_e2e<S>, robot, n, f32 ? RBDGRAD_PRECISION_F32 : RBDGRAD_PRECISION_F64,
                               kernel, pinned_memory)
      ->Unit(benchmark::kMicrosecond)->UseRealTime()->Repetitions(5)->ReportAggregatesOnly(true);
}

// cuda_e2e: the anchors' sizes with the plugin's defaults (the kernel chosen by size, copies
// skipped for small batches), the caller's arrays pinned (the anchors' pinned columns) and
// pageable; then the defaults with every kernel timed by events, the generic kernels instead
// of the robot's, the block kernel with copies at every size, and the one-thread kernel;
// cuda_shape: the block kernel's shapes at a few sizes, to choose the default by measurement.
const bool registered = [] {
  const Kernel kernels[] = {default_kernel(), timed_kernel(),   generic_kernel(), block_kernel(false),
                            thread_kernel(),  f32_arithmetic(), no_graphs()};
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (const Kernel& kernel : kernels)
      for (std::size_t n : {16, 32, 64, 128, 256, 1024, 4096, 16384, 65536}) {
        // the one-thread kernel (the first increment) at one small size and from 1024 on, where
        // it competes (the choice between the kernels is measured there)
        if (kernel.name == "thread" && n != 16 && n < 1024) continue;
        for (const bool pinned_memory : {true, false}) {
          if (kernel.name != "default" && !pinned_memory) continue;
          add<float>("cuda_e2e", robot, n, kernel, pinned_memory);
          if (kernel.name != "f32-arith") add<double>("cuda_e2e", robot, n, kernel, pinned_memory);
        }
      }
  // cuda_warp: the warp kernel (the defaults) against the block kernel and against the warp
  // kernel compiled for any robot, side by side per size
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (std::size_t n : {16, 32, 64, 128, 256, 1024, 4096, 16384, 65536})
      for (const Kernel& kernel : {default_kernel(), no_warp(), generic_kernel()}) {
        add<float>("cuda_warp", robot, n, kernel);
        add<double>("cuda_warp", robot, n, kernel);
      }
  // cuda_warp_outputs: the warp kernel's first outputs written early or at the end, by size
  for (std::size_t n : {16, 32, 64, 128, 256, 512, 1024, 4096})
    for (const bool early : {true, false}) {
      add<float>("cuda_warp_outputs", "iiwa14", n, warp_outputs(early));
      add<double>("cuda_warp_outputs", "iiwa14", n, warp_outputs(early));
    }
  // cuda_warp_inputs: small batches' inputs in the kernel's parameters or from host memory
  for (std::size_t n : {8, 16, 32, 48})
    for (const Kernel& kernel : {warp_inputs(true), warp_inputs(true, rbdgrad::cuda::kWarpInlineInputBytes),
                                 warp_inputs(false)}) {
      add<float>("cuda_warp_inputs", "iiwa14", n, kernel);
      add<double>("cuda_warp_inputs", "iiwa14", n, kernel);
    }
  // cuda_pinned_check: small batches checking from 0, 16 KiB (the default) or 64 KiB of inputs
  // and outputs whether the caller's arrays are pinned (in place), staged below
  for (std::size_t n : {16, 32, 64, 128, 256})
    for (std::size_t bytes : {std::size_t{0}, std::size_t{16} << 10, std::size_t{64} << 10}) {
      add<float>("cuda_pinned_check", "iiwa14", n, pinned_check(bytes));
      add<double>("cuda_pinned_check", "iiwa14", n, pinned_check(bytes));
    }
  // cuda_concurrent: 1, 2 and 4 instances computing at once (states_per_s is their sum)
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (std::size_t n : {16, 256})
      for (const int threads : {1, 2, 4}) {
        const std::string name = "cuda_concurrent/" + std::to_string(threads) + "_instances/f64/" + robot + "/N" +
                                 std::to_string(n);
        benchmark::RegisterBenchmark(name.c_str(), cuda_e2e<double>, robot, n, RBDGRAD_PRECISION_F64,
                                     default_kernel(), true)
            ->Unit(benchmark::kMicrosecond)->UseRealTime()->Threads(threads)->Repetitions(5)
            ->ReportAggregatesOnly(true);
      }
  // cuda_choice: the two kernels on the large f32 batches where the one-thread kernel can win,
  // over models of several sizes (the block_kernel_wins rule in cuda_instance.cpp)
  for (const char* robot : {"iiwa14", "panda", "hyq"})
    for (std::size_t n : {32768, 65536})
      for (const Kernel& kernel : {block_kernel(true), thread_kernel()}) add<float>("cuda_choice", robot, n, kernel);
  // cuda_pipeline: how many chunks a batch that copies goes in (against the default rule,
  // chunk_states); in one chunk also with the kernels compiled for any robot (the kernel alone
  // at N = 65536, issue 4's floor goal)
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (std::size_t chunks : {1, 2, 4, 8})
      for (std::size_t n : {1024, 4096, 16384, 65536}) {
        add<float>("cuda_pipeline", robot, n, pipeline(chunks));
        add<double>("cuda_pipeline", robot, n, pipeline(chunks));
        if (chunks != 1) continue;
        add<float>("cuda_pipeline", robot, n, pipeline(chunks, false));
        add<double>("cuda_pipeline", robot, n, pipeline(chunks, false));
        // talos_reduced's block kernel with twice its threads per state, one launch (iiwa14 runs
        // the warp kernel, which the shape does not change)
        if (n != 65536 || std::string(robot) != "talos_reduced") continue;
        add<float>("cuda_pipeline", robot, n, wider(pipeline(chunks), 512));
        add<double>("cuda_pipeline", robot, n, wider(pipeline(chunks), 512));
        // and the dense block kernel, three states an SM (one block of 256 threads a state), the
        // compact one with its full working set, four, and the default (its lean working set,
        // eight states an SM at its automatic 128 threads a state) at 96 threads a state (eight,
        // at 80 registers where 128 take 64), 192 (four, by its registers) and 256 (three), and
        // the default with M^-1's columns a thread a column, walking the tree
        for (const Kernel& k : {dense(pipeline(chunks)), full(pipeline(chunks)), wider(pipeline(chunks), 96),
                                wider(pipeline(chunks), 192), wider(pipeline(chunks), 256),
                                walked_columns(pipeline(chunks))}) {
          add<float>("cuda_pipeline", robot, n, k);
          add<double>("cuda_pipeline", robot, n, k);
        }
      }
  // cuda_compact: talos_reduced's block kernel, the default (compact with its lean working set:
  // eight states an SM at the 128 threads a state of its automatic shape for large launches,
  // block_shape_for) against the dense one and the compact one with its full working set (four
  // states an SM), end to end at the anchors' sizes; from 1024 states also the default at 192
  // and 256 threads a state for every launch (four and three states an SM by its registers),
  // which chose its shape by the states of a launch
  for (std::size_t n : {16, 32, 64, 128, 256, 1024, 4096, 16384, 65536}) {
    std::vector<Kernel> builds{default_kernel(), dense(default_kernel()), full(default_kernel())};
    if (n >= 1024) {
      builds.push_back(wider(default_kernel(), 192));
      builds.push_back(wider(default_kernel(), 256));
    }
    for (const Kernel& kernel : builds) {
      add<float>("cuda_compact", "talos_reduced", n, kernel);
      add<double>("cuda_compact", "talos_reduced", n, kernel);
    }
  }
  // cuda_waves: iiwa14's warp kernel in one launch at 15 and 16 full waves of an H200 (132 SMs x 8
  // warps x 4 states: 4224 states a wave) around the 15.5 of 65536 states: whether the last,
  // half-full wave costs a whole one (issue 4's floor goal at 65536 states)
  for (std::size_t n : {std::size_t{15 * 4224}, std::size_t{65536}, std::size_t{16 * 4224}}) {
    add<float>("cuda_waves", "iiwa14", n, pipeline(1));
    add<double>("cuda_waves", "iiwa14", n, pipeline(1));
  }
  // cuda_mapped: mapped memory at sizes where the defaults copy
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (std::size_t n : {64, 256, 1024, 4096, 16384, 65536}) {
      add<float>("cuda_mapped", robot, n, mapped_io());
      add<double>("cuda_mapped", robot, n, mapped_io());
    }
  // cuda_wide: the small batches' threads per state, the default's 256 against 512 (a wider group
  // shortens the passes with more items than threads)
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (const int tps : {256, 512})
      for (std::size_t n : {16, 64, 256}) {
        add<float>("cuda_wide", robot, n, block_kernel(tps, 1));
        add<double>("cuda_wide", robot, n, block_kernel(tps, 1));
      }
  const std::pair<int, int> shapes[] = {{32, 1}, {64, 1}, {64, 2}, {128, 1}, {256, 1}};
  for (const char* robot : {"iiwa14", "talos_reduced"})
    for (const auto& [tps, spb] : shapes)
      for (std::size_t n : {16, 1024, 65536}) {
        add<float>("cuda_shape", robot, n, block_kernel(tps, spb));
        add<double>("cuda_shape", robot, n, block_kernel(tps, spb));
      }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
