// Which kernel a CudaInstance runs (plugins/cuda/cuda_instance.cpp): the block kernel for the
// gradient requests it takes, up to block_max_states states and within the device's shared
// memory; the one-thread kernel for everything else. Needs a GPU (skips with the reason without).
#include <gtest/gtest.h>

#include <cuda_runtime_api.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <type_traits>
#include <vector>

#include "../../support/test_models.hpp"
#include "cuda_instance.hpp"

namespace rbdgrad::cuda {
namespace {

// One batch from tau of n equal states in S (double or float), every output array allocated.
template <class S = double>
struct OneBatch {
  std::vector<S> q, qd, tau, qdd, minv, dq, dqd, M;
  std::vector<std::int32_t> status;
  rbdgrad_batch b{};
  OneBatch(int nv, std::size_t n, std::uint32_t outputs)
      : q(n * nv, S(0.1)), qd(n * nv, S(0.2)), tau(n * nv, S(0.3)), qdd(n * nv), minv(n * nv * nv), dq(n * nv * nv),
        dqd(n * nv * nv), M(n * nv * nv), status(n) {
    b.struct_size = sizeof(b);
    b.n = n;
    b.precision = std::is_same_v<S, float> ? RBDGRAD_PRECISION_F32 : RBDGRAD_PRECISION_F64;
    b.input_kind = RBDGRAD_INPUT_TAU;
    b.outputs = outputs;
    b.q = q.data();
    b.qd = qd.data();
    b.u = tau.data();
    b.qdd = qdd.data();
    b.minv_out = minv.data();
    b.dqdd_dq = dq.data();
    b.dqdd_dqd = dqd.data();
    b.m = M.data();
    b.state_status = status.data();
  }
};

TEST(CudaKernelChoice, GradientRequestsRunTheBlockKernel) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  OneBatch<> run(model.nv, 100, gradient);
  ASSERT_TRUE(instance->compute(&run.b));
  EXPECT_TRUE(instance->last_used_block_kernel());
  EXPECT_TRUE(instance->last_used_mapped_io()) << "100 states: no copies by default";
  OneBatch<> with_m(model.nv, 100, gradient | RBDGRAD_OUTPUT_M);
  ASSERT_TRUE(instance->compute(&with_m.b));
  EXPECT_FALSE(instance->last_used_block_kernel()) << "M is not a block-kernel output";
  // the same numbers from both kernels (to rounding)
  for (std::size_t e = 0; e < run.dq.size(); ++e) EXPECT_NEAR(run.dq[e], with_m.dq[e], 1e-9 * (1 + std::abs(run.dq[e])));

  KernelOptions options;
  options.block_max_states = 99;
  options.mapped_io_max_kib = 0;
  ASSERT_TRUE(instance->set_kernel_options(options));
  OneBatch<> again(model.nv, 100, gradient);
  ASSERT_TRUE(instance->compute(&again.b));
  EXPECT_FALSE(instance->last_used_block_kernel()) << "100 states, more than block_max_states";
  EXPECT_FALSE(instance->last_used_mapped_io());
  // copies or none, either kernel: the same numbers
  for (std::size_t e = 0; e < run.dq.size(); ++e) EXPECT_NEAR(run.dq[e], again.dq[e], 1e-9 * (1 + std::abs(run.dq[e])));
  options.block_shape = {1024, 2};
  EXPECT_FALSE(instance->set_kernel_options(options));
}

// Large f32 batches of small models go to the one-thread kernel (measured faster there); f64
// batches and large models stay on the block kernel.
TEST(CudaKernelChoice, LargeF32BatchesOfSmallModelsRunTheOneThreadKernel) {
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    const Model model = testing::load_embedded(robot);
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    KernelOptions options;
    options.f32_thread_kernel_min_states = 64;  // the rule at a size a test can afford
    ASSERT_TRUE(instance->set_kernel_options(options));
    const bool small_model = model.nv <= kThreadKernelMaxNv;
    OneBatch<float> below(model.nv, 63, gradient), at(model.nv, 64, gradient);
    ASSERT_TRUE(instance->compute(&below.b));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot << ": 63 states";
    ASSERT_TRUE(instance->compute(&at.b));
    EXPECT_EQ(instance->last_used_block_kernel(), !small_model) << robot << ": 64 states";
    // the same numbers from either kernel (to f32 rounding)
    for (std::size_t e = 0; e < below.dq.size(); ++e)
      EXPECT_NEAR(below.dq[e], at.dq[e], 1e-3f * (1 + std::abs(below.dq[e]))) << robot;
    OneBatch<double> f64(model.nv, 64, gradient);
    ASSERT_TRUE(instance->compute(&f64.b));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot << ": f64";
    options.f32_thread_kernel_min_states = 0;  // never
    ASSERT_TRUE(instance->set_kernel_options(options));
    ASSERT_TRUE(instance->compute(&at.b));
    EXPECT_TRUE(instance->last_used_block_kernel()) << robot;
  }
}

TEST(CudaKernelChoice, TooMuchSharedMemoryFallsBackToTheOneThreadKernel) {
  const Model model = testing::load_embedded("talos_reduced");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  KernelOptions options;
  options.block_shape = {32, 32};  // 32 talos states of about 100 KB each: more than any GPU's block
  ASSERT_TRUE(instance->set_kernel_options(options));
  OneBatch<> run(model.nv, 40, RBDGRAD_OUTPUT_DQDD_DQ);
  ASSERT_TRUE(instance->compute(&run.b));
  EXPECT_FALSE(instance->last_used_block_kernel());
  for (std::int32_t s : run.status) EXPECT_EQ(s, 0);
}

// A caller whose arrays are pinned (cudaMallocHost) gets them moved without staging, in one chunk
// and in several, and the same numbers as a caller with ordinary memory.
TEST(CudaPinnedCaller, PinnedArraysSkipTheStaging) {
  const Model model = testing::load_embedded("iiwa14");
  std::unique_ptr<CudaInstance> instance;
  if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
  const std::uint32_t gradient = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD;
  for (const std::size_t n : {1000u, 3 * 8192u + 7}) {
    OneBatch<> pageable(model.nv, n, gradient);
    for (std::size_t e = 0; e < pageable.q.size(); ++e) pageable.q[e] = 0.001 * static_cast<double>(e % 1000);
    ASSERT_TRUE(instance->compute(&pageable.b));
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
    rbdgrad_batch b = pageable.b;
    b.q = pin(pageable.q);
    b.qd = pin(pageable.qd);
    b.u = pin(pageable.tau);
    double* qdd = pin(pageable.qdd);
    double* dq = pin(pageable.dq);
    double* dqd = pin(pageable.dqd);
    std::vector<std::int32_t> status(n, -1);
    b.qdd = qdd;
    b.dqdd_dq = dq;
    b.dqdd_dqd = dqd;
    b.state_status = status.data();
    for (std::size_t e = 0; e < n * model.nv * model.nv; ++e) dq[e] = dqd[e] = std::nan("");
    for (std::size_t e = 0; e < n * model.nv; ++e) qdd[e] = std::nan("");
    ASSERT_TRUE(instance->compute(&b));
    EXPECT_EQ(instance->last_pinned_arrays(), 6) << n << " states";
    for (std::size_t e = 0; e < pageable.dq.size(); ++e) {
      ASSERT_EQ(dq[e], pageable.dq[e]) << n << " states, element " << e;
      ASSERT_EQ(dqd[e], pageable.dqd[e]) << n << " states, element " << e;
    }
    for (std::size_t e = 0; e < pageable.qdd.size(); ++e) ASSERT_EQ(qdd[e], pageable.qdd[e]) << e;
    for (std::int32_t s : status) ASSERT_EQ(s, 0);
    for (void* p : pinned) cudaFreeHost(p);
  }
}

}  // namespace
}  // namespace rbdgrad::cuda
