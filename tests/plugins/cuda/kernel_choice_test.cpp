// Which kernel a CudaInstance runs (plugins/cuda/cuda_instance.cpp): the block kernel for the
// gradient requests it takes, up to block_max_states states and within the device's shared
// memory; the one-thread kernel for everything else. Needs a GPU (skips with the reason without).
#include <gtest/gtest.h>

#include <cuda_runtime_api.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <memory>
#include <random>
#include <type_traits>
#include <utility>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "cuda_instance.hpp"

namespace rbdgrad::cuda {
namespace {

// n equal states in S (double or float), from tau: the plugin tests' batch arrays (outputs
// prefilled with a marker)
template <class S = double>
testing::BatchArrays<S> equal_states(int nv, std::size_t n) {
  testing::BatchArrays<S> a(n, nv);
  std::fill(a.q.begin(), a.q.end(), S(0.1));
  std::fill(a.qd.begin(), a.qd.end(), S(0.2));
  std::fill(a.u.begin(), a.u.end(), S(0.3));
  return a;
}

template <class S>
rbdgrad_batch batch_of(testing::BatchArrays<S>& a, std::uint32_t outputs) {
  return a.batch(std::is_same_v<S, float> ? RBDGRAD_PRECISION_F32 : RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, outputs,
                 false, false);
}

// A batch of one block-kernel launch without copies goes as a CUDA Graph (kernel_graphs.hpp), whose
// kernel node takes each call's arrays and size: the same bits as the stream launch, call after
// call with different batches; with copies, or with graphs off, a stream launch.
TEST(CudaKernelChoice, SmallMappedBatchesLaunchAsAGraph) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> with_graphs, without;
  if (Status s = CudaInstance::create(model, 0, with_graphs); !s) GTEST_SKIP() << "no GPU: " << s.message();
  ASSERT_TRUE(CudaInstance::create(model, 0, without));
  (void)with_graphs->specialize("");
  (void)without->specialize("");
  KernelOptions off;
  off.graphs = false;
  ASSERT_TRUE(without->set_kernel_options(off));
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const std::size_t n : {7u, 33u, 1u, 200u}) {
    auto a = equal_states(model.nv, n), b = equal_states(model.nv, n);
    for (std::vector<double>* v : {&a.q, &a.qd, &a.u})
      for (double& x : *v) x = u(rng);
    b.q = a.q;
    b.qd = a.qd;
    b.u = a.u;
    rbdgrad_batch x = batch_of(a, gradient), y = batch_of(b, gradient);
    ASSERT_TRUE(with_graphs->compute(&x));
    EXPECT_TRUE(with_graphs->last_used_mapped_io()) << n;
    EXPECT_TRUE(with_graphs->last_used_graph()) << n;
    ASSERT_TRUE(without->compute(&y));
    EXPECT_FALSE(without->last_used_graph()) << n;
    for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_DQDD_DQ, RBDGRAD_OUTPUT_DQDD_DQD})
      ASSERT_EQ(a.out(flag), b.out(flag)) << "n = " << n << ", output " << flag;
  }
  KernelOptions copies;
  copies.mapped_io_max_kib = copies.mapped_pinned_max_kib = 0;
  ASSERT_TRUE(with_graphs->set_kernel_options(copies));
  auto c = equal_states(model.nv, 16);
  rbdgrad_batch z = batch_of(c, gradient);
  ASSERT_TRUE(with_graphs->compute(&z));
  EXPECT_FALSE(with_graphs->last_used_graph()) << "a batch with copies launches on its stream";
}

TEST(CudaKernelChoice, GradientRequestsRunTheBlockKernel) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  auto run = equal_states(model.nv, 100);
  rbdgrad_batch b = batch_of(run, gradient);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_TRUE(instance->last_used_block_kernel());
  EXPECT_TRUE(instance->last_used_warp_kernel()) << "an f64 gradient request of 7 joints";
  EXPECT_TRUE(instance->last_used_mapped_io()) << "100 states: no copies by default";
  EXPECT_EQ(instance->last_kernel_ms(), 0.0f) << "the kernel is timed only when asked";
  auto with_m = equal_states(model.nv, 100);
  b = batch_of(with_m, gradient | RBDGRAD_OUTPUT_M);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_FALSE(instance->last_used_block_kernel()) << "M is not a block-kernel output";
  // the same numbers from both kernels (to rounding)
  const std::vector<double>& dq = run.out(RBDGRAD_OUTPUT_DQDD_DQ);
  for (std::size_t e = 0; e < dq.size(); ++e)
    EXPECT_NEAR(dq[e], with_m.out(RBDGRAD_OUTPUT_DQDD_DQ)[e], 1e-9 * (1 + std::abs(dq[e])));

  // the block kernel instead of the warp kernel: the same numbers
  KernelOptions options;
  options.warp_kernel = false;
  ASSERT_TRUE(instance->set_kernel_options(options));
  auto block = equal_states(model.nv, 100);
  b = batch_of(block, gradient);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_TRUE(instance->last_used_block_kernel());
  EXPECT_FALSE(instance->last_used_warp_kernel());
  for (std::size_t e = 0; e < dq.size(); ++e)
    EXPECT_NEAR(dq[e], block.out(RBDGRAD_OUTPUT_DQDD_DQ)[e], 1e-9 * (1 + std::abs(dq[e])));

  options = KernelOptions{};
  options.block_max_states = 99;
  options.mapped_io_max_kib = 0;
  ASSERT_TRUE(instance->set_kernel_options(options));
  auto again = equal_states(model.nv, 100);
  b = batch_of(again, gradient);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_FALSE(instance->last_used_block_kernel()) << "100 states, more than block_max_states";
  EXPECT_FALSE(instance->last_used_mapped_io());
  // copies or none, either kernel: the same numbers
  for (std::size_t e = 0; e < dq.size(); ++e)
    EXPECT_NEAR(dq[e], again.out(RBDGRAD_OUTPUT_DQDD_DQ)[e], 1e-9 * (1 + std::abs(dq[e])));
  // timed on request, in one chunk and in several (a pinned caller's large batch, below, runs
  // chunks untimed)
  options.time_kernel = true;
  ASSERT_TRUE(instance->set_kernel_options(options));
  for (const std::size_t n : {100u, 4 * 8192u}) {
    auto timed = equal_states(model.nv, n);
    b = batch_of(timed, gradient);
    ASSERT_TRUE(instance->compute(&b));
    EXPECT_GT(instance->last_kernel_ms(), 0.0f) << n << " states";
    EXPECT_NEAR(timed.out(RBDGRAD_OUTPUT_DQDD_DQ)[0], dq[0], 1e-9 * (1 + std::abs(dq[0]))) << n << " states";
  }
  options.block_shape = {1024, 2};
  EXPECT_FALSE(instance->set_kernel_options(options));
}

// The warp kernel writes a large batch's first outputs before computing d tau/d q and a small
// batch's at the end (warp_early_outputs_min_bytes): the same bits either way, for a model on
// segments of 8 lanes (iiwa14) and one on 16 (hyq), every output, a batch ending inside a warp.
TEST(CudaKernelChoice, TheWarpKernelsEarlyOutputsAreTheSameBits) {
  for (const char* robot : {"iiwa14", "hyq"}) {
    const Model model = testing::load_embedded(robot);
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    const std::uint32_t outputs =
        RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1, 1);
    auto early = equal_states(model.nv, 1001), late = equal_states(model.nv, 1001);
    for (std::vector<double>* v : {&early.q, &early.qd, &early.u})
      for (double& x : *v) x = u(rng);
    late.q = early.q;
    late.qd = early.qd;
    late.u = early.u;
    for (auto* run : {&early, &late}) {
      KernelOptions options;
      options.warp_early_outputs_min_bytes = run == &early ? 0 : ~std::uint64_t{0};
      ASSERT_TRUE(instance->set_kernel_options(options));
      rbdgrad_batch b = batch_of(*run, outputs);
      ASSERT_TRUE(instance->compute(&b)) << robot;
      ASSERT_TRUE(instance->last_used_warp_kernel()) << robot;
    }
    for (const std::uint32_t flag :
         {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_DQDD_DQ, RBDGRAD_OUTPUT_DQDD_DQD, RBDGRAD_OUTPUT_MINV})
      ASSERT_EQ(early.out(flag), late.out(flag)) << robot << ", output " << flag;
  }
}

// A small warp-kernel batch carries q, qd and u in the kernel's parameters (up to
// kWarpInlineInputBytes, without external forces or M^-1) in the smallest block of 2, 4 or 8 KiB
// that holds them: the same bits as from host memory and as in the largest block, f64 and f32,
// batches ending inside a warp and filling a block; larger ones read host memory.
TEST(CudaKernelChoice, SmallBatchesCarryTheirInputsInTheKernelsParameters) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  const std::uint32_t outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  const std::size_t nv = static_cast<std::size_t>(model.nv);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  // block: the parameter block expected (0: host memory)
  const auto check = [&](auto scalar, std::size_t n, std::size_t block) {
    using S = decltype(scalar);
    auto in_params = equal_states<S>(model.nv, n), largest = equal_states<S>(model.nv, n),
         from_host = equal_states<S>(model.nv, n);
    for (std::vector<S>* v : {&in_params.q, &in_params.qd, &in_params.u})
      for (S& x : *v) x = static_cast<S>(u(rng));
    for (auto* other : {&largest, &from_host}) {
      other->q = in_params.q;
      other->qd = in_params.qd;
      other->u = in_params.u;
    }
    for (auto* run : {&in_params, &largest, &from_host}) {
      KernelOptions options;
      options.warp_inline_inputs = run != &from_host;
      if (run == &largest) options.warp_inline_min_block = kWarpInlineInputBytes;
      ASSERT_TRUE(instance->set_kernel_options(options));
      rbdgrad_batch b = batch_of(*run, outputs);
      ASSERT_TRUE(instance->compute(&b)) << n;
      EXPECT_TRUE(instance->last_used_warp_kernel()) << n;
      const std::size_t expected = run == &from_host ? 0 : run == &largest && block != 0 ? kWarpInlineInputBytes : block;
      EXPECT_EQ(instance->last_inline_block_bytes(), expected) << n << " states, " << sizeof(S) << "-byte scalars";
    }
    for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_DQDD_DQ, RBDGRAD_OUTPUT_DQDD_DQD}) {
      ASSERT_EQ(in_params.out(flag), from_host.out(flag)) << n << " states, output " << flag;
      ASSERT_EQ(largest.out(flag), from_host.out(flag)) << n << " states, output " << flag;
    }
  };
  // f64, 168 bytes a state: 12 states fill 2016 of 2048 bytes, 24 fill 4032 of 4096, 48 fill 8064
  // of 8192, 49 do not fit; f32, 84 bytes a state: 97 fit, 98 do not
  const std::pair<std::size_t, std::size_t> f64_cases[] = {{1, 2048},   {7, 2048},   {12, 2048}, {13, 4096},
                                                           {24, 4096},  {33, 8192},  {48, 8192}, {49, 0}};
  for (const auto& [n, block] : f64_cases) check(double{}, n, block);
  const std::pair<std::size_t, std::size_t> f32_cases[] = {{7, 2048}, {32, 4096}, {97, 8192}, {98, 0}};
  for (const auto& [n, block] : f32_cases) check(float{}, n, block);
  // with external forces the inputs stay in host memory
  auto forces = equal_states(model.nv, 7);
  rbdgrad_batch b = batch_of(forces, outputs);
  std::vector<double> fext(7 * 6 * nv, 0.5);
  b.fext = fext.data();
  ASSERT_TRUE(instance->set_kernel_options(KernelOptions{}));
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_TRUE(instance->last_used_warp_kernel());
  EXPECT_EQ(instance->last_inline_block_bytes(), 0u);
}

// Large f32 batches of small models computed in f32 go to the one-thread kernel (measured faster
// there); f64 batches, large models and f32 batches computed in f64 stay on the block kernel.
TEST(CudaKernelChoice, LargeF32BatchesOfSmallModelsRunTheOneThreadKernel) {
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    const Model model = testing::load_embedded(robot);
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    KernelOptions options;
    options.f32_thread_kernel_min_states = 64;  // the rule at a size a test can afford
    options.f32_compute = F32Compute::kF32;
    ASSERT_TRUE(instance->set_kernel_options(options));
    const bool small_model = model.nv <= kThreadKernelMaxNv;
    auto below = equal_states<float>(model.nv, 63);
    auto at = equal_states<float>(model.nv, 64);
    rbdgrad_batch b_below = batch_of(below, gradient), b_at = batch_of(at, gradient);
    ASSERT_TRUE(instance->compute(&b_below));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot << ": 63 states";
    ASSERT_TRUE(instance->compute(&b_at));
    EXPECT_EQ(instance->last_used_block_kernel(), !small_model) << robot << ": 64 states";
    // the same numbers from either kernel (to f32 rounding)
    const std::vector<float>& dq = below.out(RBDGRAD_OUTPUT_DQDD_DQ);
    for (std::size_t e = 0; e < dq.size(); ++e)
      EXPECT_NEAR(dq[e], at.out(RBDGRAD_OUTPUT_DQDD_DQ)[e], 1e-3f * (1 + std::abs(dq[e]))) << robot;
    auto f64 = equal_states<double>(model.nv, 64);
    rbdgrad_batch b_f64 = batch_of(f64, gradient);
    ASSERT_TRUE(instance->compute(&b_f64));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot << ": f64";
    options.f32_compute = F32Compute::kF64;
    ASSERT_TRUE(instance->set_kernel_options(options));
    ASSERT_TRUE(instance->compute(&b_at));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot << ": computed in f64";
    options.f32_thread_kernel_min_states = 0;  // never
    options.f32_compute = F32Compute::kF32;
    ASSERT_TRUE(instance->set_kernel_options(options));
    ASSERT_TRUE(instance->compute(&b_at));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot;
  }
}

// An f32 batch computed in f64 (F32Compute) reads f32 inputs and writes f64 results rounded to
// f32: equal to the f64 batch of the same inputs to f32 rounding, where f32 arithmetic is off by
// up to about cond(M) times that. auto computes in f64 exactly where the GPU's f64 is fast.
TEST(CudaKernelChoice, F32BatchesComputedInF64AreTheF64ResultsRounded) {
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD |
                                 RBDGRAD_OUTPUT_MINV;
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    const Model model = testing::load_embedded(robot);
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    (void)instance->specialize("");  // the robot-specific kernels where NVRTC is present, else the generic ones
    std::printf("%s: %s\n", robot, instance->kernel_description().c_str());
    for (const std::size_t n : {7u, 1000u}) {  // mapped I/O and copies
      testing::BatchArrays<float> single(n, model.nv);
      testing::BatchArrays<double> wide(n, model.nv);
      std::mt19937 rng(static_cast<unsigned>(n));
      std::uniform_real_distribution<float> u(-1.5f, 1.5f);
      for (std::size_t e = 0; e < single.q.size(); ++e) {
        single.q[e] = u(rng), single.qd[e] = u(rng), single.u[e] = 10 * u(rng);
        wide.q[e] = single.q[e], wide.qd[e] = single.qd[e], wide.u[e] = single.u[e];
      }
      rbdgrad_batch bw = batch_of(wide, gradient);
      ASSERT_TRUE(instance->compute(&bw));
      double worst_in_f64 = 0, worst_in_f32 = 0;
      for (const F32Compute compute : {F32Compute::kF64, F32Compute::kF32}) {
        KernelOptions options;
        options.f32_compute = compute;
        ASSERT_TRUE(instance->set_kernel_options(options));
        testing::BatchArrays<float> run = single;
        rbdgrad_batch b = batch_of(run, gradient);
        ASSERT_TRUE(instance->compute(&b));
        EXPECT_EQ(instance->last_computed_f32_in_f64(), compute == F32Compute::kF64) << robot;
        EXPECT_TRUE(instance->last_used_block_kernel()) << robot;
        double& worst = compute == F32Compute::kF64 ? worst_in_f64 : worst_in_f32;
        for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_MINV, RBDGRAD_OUTPUT_DQDD_DQ,
                                         RBDGRAD_OUTPUT_DQDD_DQD}) {
          const std::vector<double>& want = wide.out(flag);
          const std::vector<float>& got = run.out(flag);
          for (std::size_t e = 0; e < want.size(); ++e)
            worst = std::max(worst, std::abs(got[e] - want[e]) / (1e-3 + std::abs(want[e])));
        }
        for (std::int32_t s : run.state_status) ASSERT_EQ(s, 0) << robot;
      }
      std::printf("%s, %zu states: worst relative difference from f64, computed in f64 %.2e, in f32 %.2e\n", robot,
                  n, worst_in_f64, worst_in_f32);
      // rounding to f32 is within 2^-24 relative; the margin is for the 1e-3 floor's neighbours
      EXPECT_LE(worst_in_f64, 1.2e-7) << robot << ", " << n << " states";
      EXPECT_GT(worst_in_f32, worst_in_f64) << robot << ", " << n << " states";
    }
    KernelOptions automatic;
    ASSERT_TRUE(instance->set_kernel_options(automatic));
    int ratio = 0;
    ASSERT_EQ(cudaDeviceGetAttribute(&ratio, cudaDevAttrSingleToDoublePrecisionPerfRatio, 0), cudaSuccess);
    EXPECT_EQ(instance->f32_in_f64(), ratio <= kFastF64MaxRatio) << "f32 to f64 rate ratio " << ratio;
  }
}

// A block-kernel batch is chunked by the rule alone; a one-thread-kernel batch in whole passes of
// the workspace's slots (which the block kernel does not use), and both compute the same.
TEST(CudaKernelChoice, OnlyTheOneThreadKernelIsChunkedByTheWorkspace) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance, std::size_t{1} << 20); !s)
    GTEST_SKIP() << "no GPU: " << s.message();
  ASSERT_LT(instance->slots(), 4096u / 8) << "a 1 MiB workspace holds few slots";
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  auto block = equal_states(model.nv, 4096);
  rbdgrad_batch b = batch_of(block, gradient);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_TRUE(instance->last_used_block_kernel());
  EXPECT_EQ(instance->last_chunks(), 4096u / chunk_min_states(model.nv));
  KernelOptions options;
  options.block_max_states = 0;
  ASSERT_TRUE(instance->set_kernel_options(options));
  auto thread = equal_states(model.nv, 4096);
  b = batch_of(thread, gradient);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_FALSE(instance->last_used_block_kernel());
  EXPECT_EQ(instance->last_chunks(), kMaxChunks);
  const std::vector<double>& dq = block.out(RBDGRAD_OUTPUT_DQDD_DQ);
  for (std::size_t e = 0; e < dq.size(); ++e)
    ASSERT_NEAR(dq[e], thread.out(RBDGRAD_OUTPUT_DQDD_DQ)[e], 1e-9 * (1 + std::abs(dq[e]))) << e;
}

TEST(CudaKernelChoice, TooMuchSharedMemoryFallsBackToTheOneThreadKernel) {
  const Model model = testing::load_embedded("talos_reduced");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  KernelOptions options;
  options.block_shape = {32, 32};  // 32 talos states of about 100 KB each: more than any GPU's block
  ASSERT_TRUE(instance->set_kernel_options(options));
  auto run = equal_states(model.nv, 40);
  rbdgrad_batch b = batch_of(run, RBDGRAD_OUTPUT_DQDD_DQ);
  ASSERT_TRUE(instance->compute(&b));
  EXPECT_FALSE(instance->last_used_block_kernel());
  for (std::int32_t s : run.state_status) EXPECT_EQ(s, 0);
}

// A caller whose arrays are pinned (cudaMallocHost) gets them moved without staging, or worked on
// in place with mapped memory, in one chunk and in several, and the same numbers as a caller with
// ordinary memory.
TEST(CudaPinnedCaller, PinnedArraysSkipTheStaging) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  // 8 and 200 states: mapped memory, the smaller one staged unchecked (kMappedPinnedCheckMinBytes),
  // the larger one worked on in place; 1000: mapped in place (every array pinned, within
  // mapped_pinned_max_kib); 3 * 8192 + 7: copies in chunks
  for (const std::size_t n : {8u, 200u, 1000u, 3 * 8192u + 7}) {
    auto pageable = equal_states(model.nv, n);
    for (std::size_t e = 0; e < pageable.q.size(); ++e) pageable.q[e] = 0.001 * static_cast<double>(e % 1000);
    const rbdgrad_batch pageable_batch = batch_of(pageable, gradient);
    ASSERT_TRUE(instance->compute(&pageable_batch));
    EXPECT_EQ(instance->last_pinned_arrays(), 0);
    // the same batch in pinned copies of every array
    std::vector<void*> pinned;
    auto pin = [&](const std::vector<double>& from) {
      void* p = nullptr;
      if (cudaMallocHost(&p, from.size() * sizeof(double)) != cudaSuccess) return static_cast<double*>(nullptr);
      std::memcpy(p, from.data(), from.size() * sizeof(double));
      pinned.push_back(p);
      return static_cast<double*>(p);
    };
    const std::vector<double>& want_qdd = pageable.out(RBDGRAD_OUTPUT_QDD);
    const std::vector<double>& want_dq = pageable.out(RBDGRAD_OUTPUT_DQDD_DQ);
    const std::vector<double>& want_dqd = pageable.out(RBDGRAD_OUTPUT_DQDD_DQD);
    rbdgrad_batch b = pageable_batch;
    b.q = pin(pageable.q);
    b.qd = pin(pageable.qd);
    b.u = pin(pageable.u);
    double* qdd = pin(want_qdd);
    double* dq = pin(want_dq);
    double* dqd = pin(want_dqd);
    std::vector<std::int32_t> status(n, -1);
    b.qdd = qdd;
    b.dqdd_dq = dq;
    b.dqdd_dqd = dqd;
    b.state_status = status.data();
    for (std::size_t e = 0; e < n * model.nv * model.nv; ++e) dq[e] = dqd[e] = std::nan("");
    for (std::size_t e = 0; e < n * model.nv; ++e) qdd[e] = std::nan("");
    ASSERT_TRUE(instance->compute(&b));
    EXPECT_EQ(instance->last_used_mapped_io(), n <= 1000) << n << " states";
    EXPECT_EQ(instance->last_pinned_arrays(), n == 8 ? 0 : 6) << n << " states";
    for (std::size_t e = 0; e < want_dq.size(); ++e) {
      ASSERT_EQ(dq[e], want_dq[e]) << n << " states, element " << e;
      ASSERT_EQ(dqd[e], want_dqd[e]) << n << " states, element " << e;
    }
    for (std::size_t e = 0; e < want_qdd.size(); ++e) ASSERT_EQ(qdd[e], want_qdd[e]) << e;
    for (std::int32_t s : status) ASSERT_EQ(s, 0);
    for (void* p : pinned) cudaFreeHost(p);
  }
}

}  // namespace
}  // namespace rbdgrad::cuda
