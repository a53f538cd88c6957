// The block and warp kernels compiled for the robot at load (CudaInstance::specialize, NVRTC)
// against the generic ones compiled into the plugin: the same numbers to rounding for every
// shipped robot, both precisions, both input kinds, odd and even batch sizes, every output
// written. Needs a GPU and NVRTC; skips with the reason without either. (The plugin tests, cuda_plugin_test.cpp, check the
// plugin's default, this kernel, against the Pinocchio reference.)
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "../../support/error_statistics.hpp"
#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "cuda_instance.hpp"
#include "rbdgrad/embedded_robots.hpp"

namespace rbdgrad::cuda {
namespace {

using ::testing::HasSubstr;

constexpr std::uint32_t kGradient =
    RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;

template <class S>
testing::BatchArrays<S> random_states(int nv, std::size_t n, unsigned seed) {
  testing::BatchArrays<S> a(n, nv);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> q(-2.0, 2.0), qd(-3.0, 3.0), u(-20.0, 20.0);
  for (S& x : a.q) x = static_cast<S>(q(rng));
  for (S& x : a.qd) x = static_cast<S>(qd(rng));
  for (S& x : a.u) x = static_cast<S>(u(rng));
  return a;
}

// warp: the warp kernel's two builds (models of up to kMaxWarpNv joints), else the block kernel's.
// with_minv: the caller brings M^-1 (a random matrix, its entries between the tree's blocks too),
// and the outputs are those the block kernel takes with it (no M^-1 out). The instance's other
// kernel options (the build's shape) stay as they are. Where the robot's kernel arranges the
// arithmetic otherwise (its lean working set), the two kernels' roundings in f32 arithmetic differ
// by more than the tolerance on ill-conditioned states (iiwa14: 0.14 apart on an entry of -72.0,
// where each is within 0.11 of f64), so each kernel's error against the generic kernel in f64 is
// compared instead, by the f32 bounds the suite holds the kernels to against the core
// (Comparison::within_bounds): each state's largest error within 4 times the generic f32
// kernel's or 1e-3 of the state's largest entry, and over a batch the median of those relative
// errors within twice the generic kernel's or 1e-4. A state's ratio alone says little: on the
// host, the two arrangements' errors on 60 seeds' states are the same on geometric mean (1.02 to
// 1.04 lean over generic) and 8 to 39 times apart on single states, all within the bound.
template <class S>
void compare_kernels(CudaInstance& instance, const std::string& robot, int nv,
                     F32Compute f32_compute = F32Compute::kF32, bool warp = false, bool with_minv = false) {
  const bool own_arithmetic = instance.kernel_description().find(", lean working set") != std::string::npos;
  const bool against_f64 = own_arithmetic && std::is_same_v<S, float> && f32_compute == F32Compute::kF32;
  const std::uint32_t precision = std::is_same_v<S, float> ? RBDGRAD_PRECISION_F32 : RBDGRAD_PRECISION_F64;
  // f64: the two builds differ only in constant folding and unrolling, which may contract other
  // multiply-adds; f32 the same, at its own rounding. Relative to the state's largest entry of
  // that output (at least 1): an entry that cancels to near zero keeps the rounding of the terms
  // that cancelled (iiwa14's last d qdd/d q entry: -5.8e-11 from one build, -2.9e-11 from the other)
  const double tolerance = std::is_same_v<S, float> ? 2e-4 : 1e-11;
  for (const std::uint32_t input : {RBDGRAD_INPUT_TAU, RBDGRAD_INPUT_QDD}) {
    // with the warp kernel: inputs in the parameters (1 to 33), outputs late (1000) and early
    const std::vector<std::size_t> sizes = warp ? std::vector<std::size_t>{1, 7, 33, 1000, 65536}
                                                : std::vector<std::size_t>{1, 7, 33, 1000};
    for (const std::size_t n : sizes) {
      const std::string where = std::string(warp ? "warp kernel, " : "") + robot +
                                (std::is_same_v<S, float>
                                     ? (f32_compute == F32Compute::kF64 ? " f32 computed in f64" : " f32")
                                     : " f64") +
                                (input == RBDGRAD_INPUT_TAU ? " from tau" : " from qdd") + ", " + std::to_string(n) +
                                " states";
      auto generic = random_states<S>(nv, n, static_cast<unsigned>(n) + input);
      if (with_minv) {
        std::mt19937 rng(static_cast<unsigned>(n));
        std::uniform_real_distribution<double> entry(-1.0, 1.0);
        for (S& x : generic.minv) x = static_cast<S>(entry(rng));
      }
      const std::uint32_t outputs = with_minv ? kGradient & ~RBDGRAD_OUTPUT_MINV : kGradient;
      auto specific = generic;
      KernelOptions options = instance.kernel_options();
      options.f32_compute = f32_compute;
      options.warp_kernel = warp;
      options.robot_specific = false;
      ASSERT_TRUE(instance.set_kernel_options(options));
      // the same states in f64 (against_f64)
      std::optional<testing::BatchArrays<double>> reference;
      if (against_f64) {
        reference.emplace(n, nv);
        for (std::size_t e = 0; e < generic.q.size(); ++e) {
          reference->q[e] = generic.q[e];
          reference->qd[e] = generic.qd[e];
          reference->u[e] = generic.u[e];
        }
        for (std::size_t e = 0; e < generic.minv.size(); ++e) reference->minv[e] = generic.minv[e];
        rbdgrad_batch r = reference->batch(RBDGRAD_PRECISION_F64, input, outputs, with_minv, false);
        ASSERT_TRUE(instance.compute(&r)) << where << ", in f64";
      }
      rbdgrad_batch b = generic.batch(precision, input, outputs, with_minv, false);
      ASSERT_TRUE(instance.compute(&b)) << where;
      ASSERT_TRUE(instance.last_used_block_kernel()) << where;
      ASSERT_EQ(instance.last_used_warp_kernel(), warp) << where;
      ASSERT_FALSE(instance.last_used_robot_specific_kernel()) << where;
      options.robot_specific = true;
      ASSERT_TRUE(instance.set_kernel_options(options));
      b = specific.batch(precision, input, outputs, with_minv, false);
      ASSERT_TRUE(instance.compute(&b)) << where;
      ASSERT_TRUE(instance.last_used_robot_specific_kernel()) << where;
      ASSERT_EQ(instance.last_used_warp_kernel(), warp) << where;
      for (std::size_t k = 0; k < n; ++k) ASSERT_EQ(specific.state_status[k], 0) << where << ", state " << k;
      for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_MINV, RBDGRAD_OUTPUT_DQDD_DQ,
                                       RBDGRAD_OUTPUT_DQDD_DQD}) {
        if (flag == RBDGRAD_OUTPUT_QDD && input == RBDGRAD_INPUT_QDD) continue;  // the input itself
        if ((outputs & flag) == 0) continue;
        const std::vector<S>& want = generic.out(flag);
        const std::vector<S>& got = specific.out(flag);
        const std::size_t per_state = want.size() / n;
        std::vector<double> relative_generic, relative_specific;  // against_f64: per state, of its scale
        for (std::size_t k = 0; k < n; ++k) {
          double scale = 1;
          for (std::size_t e = k * per_state; e < (k + 1) * per_state; ++e)
            scale = std::max(scale, std::abs(double(want[e])));
          double error_generic = 0, error_specific = 0;
          for (std::size_t e = k * per_state; e < (k + 1) * per_state; ++e) {
            // the arrays start at a marker (77): every element must have been written, and finite
            ASSERT_TRUE(std::isfinite(got[e])) << where << ", output " << flag << " element " << e;
            if (!against_f64) {
              ASSERT_NEAR(got[e], want[e], tolerance * scale) << where << ", output " << flag << " element " << e;
              continue;
            }
            const double exact = reference->out(flag)[e];
            error_generic = std::max(error_generic, std::abs(double(want[e]) - exact));
            error_specific = std::max(error_specific, std::abs(double(got[e]) - exact));
          }
          if (against_f64) {
            ASSERT_LE(error_specific, std::max(4 * error_generic, 1e-3 * scale))
                << where << ", output " << flag << ", state " << k << ": against f64 (generic f32 " << error_generic
                << ", the state's largest entry " << scale << ")";
            relative_generic.push_back(error_generic / scale);
            relative_specific.push_back(error_specific / scale);
          }
        }
        if (against_f64) {
          const double median_generic = testing::median_of(relative_generic);
          EXPECT_LE(testing::median_of(relative_specific), std::max(2 * median_generic, 1e-4))
              << where << ", output " << flag << ": the states' median error against f64, of their largest entry"
              << " (generic f32 " << median_generic << ")";
        }
      }
    }
  }
}

TEST(CudaRobotSpecificKernel, MatchesTheGenericKernelOnEveryRobot) {
  for (std::string_view name : embedded_robot_names()) {
    const Model model = testing::load_embedded(std::string(name));
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    EXPECT_THAT(instance->kernel_description(), HasSubstr("generic kernel")) << "before specialize()";
    if (Status s = instance->specialize(""); !s) {
      if (s.code() == StatusCode::kUnavailable) GTEST_SKIP() << "no NVRTC: " << s.message();
      FAIL() << name << ": " << s.message();
    }
    EXPECT_THAT(instance->kernel_description(), HasSubstr("kernel compiled for this robot (f64: ")) << name;
    // the compact block kernel with its lean working set by default (KernelOptions::block_compact,
    // block_lean)
    EXPECT_THAT(instance->kernel_description(), HasSubstr(", compact, lean working set")) << name;
    std::printf("%s: %s\n", std::string(name).c_str(), instance->kernel_description().c_str());
    compare_kernels<double>(*instance, std::string(name), model.nv);
    compare_kernels<float>(*instance, std::string(name), model.nv);
    // the kernel for f32 batches computed in f64 is compiled where auto uses it
    if (instance->f32_in_f64()) compare_kernels<float>(*instance, std::string(name), model.nv, F32Compute::kF64);
  }
}

// The warp kernel compiled for the robot (its joint count and depth fixed) against the generic
// one, for every robot it takes: f64 batches, and f32 batches where they compute in f64.
TEST(CudaRobotSpecificKernel, WarpKernelMatchesTheGenericOneOnEveryRobot) {
  for (std::string_view name : embedded_robot_names()) {
    const Model model = testing::load_embedded(std::string(name));
    if (model.nv > kMaxWarpNv) continue;
    std::unique_ptr<CudaInstance> instance;
    if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
    if (Status s = instance->specialize(""); !s) {
      if (s.code() == StatusCode::kUnavailable) GTEST_SKIP() << "no NVRTC: " << s.message();
      FAIL() << name << ": " << s.message();
    }
    EXPECT_THAT(instance->kernel_description(), HasSubstr("on the warp kernel (compiled for this robot: ")) << name;
    compare_kernels<double>(*instance, std::string(name), model.nv, F32Compute::kF32, true);
    if (instance->f32_in_f64())
      compare_kernels<float>(*instance, std::string(name), model.nv, F32Compute::kF64, true);
  }
}

// The block kernels compared in f64, f32 and (where the GPU does) f32 computed in f64, with M^-1
// computed and brought by the caller.
void compare_block_kernels(CudaInstance& instance, const std::string& robot, int nv) {
  for (const bool with_minv : {false, true}) {
    compare_kernels<double>(instance, robot, nv, F32Compute::kF32, false, with_minv);
    compare_kernels<float>(instance, robot, nv, F32Compute::kF32, false, with_minv);
    if (instance.f32_in_f64()) compare_kernels<float>(instance, robot, nv, F32Compute::kF64, false, with_minv);
  }
}

// A build of the block kernel compiled for the robot against the generic one, on a humanoid whose
// legs and torso pack, a quadruped whose legs do and a chain that packs nothing, with M^-1
// computed and brought by the caller.
struct BlockBuildCase {
  bool compact, lean;
  int threads_per_state;  // 0: the automatic shape (block_shape_for)
  bool tree_chains = false;
  bool tree_columns = false;
};
void expect_builds_match_the_generic_kernel(std::initializer_list<BlockBuildCase> builds) {
  for (const char* name : {"talos_reduced", "hyq", "iiwa14"}) {
    for (const BlockBuildCase& build : builds) {
      const Model model = testing::load_embedded(name);
      std::unique_ptr<CudaInstance> instance;
      if (Status s = CudaInstance::create(model, 0, instance); !s) GTEST_SKIP() << "no GPU: " << s.message();
      KernelOptions options;
      options.block_compact = build.compact;
      options.block_lean = build.lean;
      options.block_tree_chains = build.tree_chains;
      options.block_tree_columns = build.tree_columns;
      options.block_shape.threads_per_state = build.threads_per_state;
      ASSERT_TRUE(instance->set_kernel_options(options));
      if (Status s = instance->specialize(""); !s) {
        if (s.code() == StatusCode::kUnavailable) GTEST_SKIP() << "no NVRTC: " << s.message();
        FAIL() << name << ": " << s.message();
      }
      const std::string description = instance->kernel_description();
      EXPECT_EQ(description.find(", compact") != std::string::npos, build.compact) << name << ": " << description;
      EXPECT_EQ(description.find(", lean working set") != std::string::npos, build.lean) << name << ": " << description;
      EXPECT_EQ(description.find(", M^-1 by the tree's chains") != std::string::npos, build.tree_chains)
          << name << ": " << description;
      EXPECT_EQ(description.find(", its columns by the tree's blocks") != std::string::npos, build.tree_columns)
          << name << ": " << description;
      std::printf("%s (%d threads a state, 0 automatic): %s\n", name, build.threads_per_state, description.c_str());
      compare_block_kernels(*instance, name, model.nv);
    }
  }
}

// The default build: compact (the robot's scalar constants in device memory, the matrices packed
// by the roots' blocks, its registers capped) with the lean working set, at 128 threads a state
// (its automatic shape for launches of over 256 states; first, so that compute-sanitizer's first
// launches check it), at its automatic shape (by the states of each launch: the test's batches go
// in chunks, and talos_reduced's 1000 states in chunks of at most 256) and at 256.
TEST(CudaRobotSpecificKernel, LeanKernelMatchesTheGenericOne) {
  expect_builds_match_the_generic_kernel({{true, true, 128}, {true, true, 0}, {true, true, 256}});
}

// The lean build with M^-1 by the tree's chains (block_tree_chains; talos_reduced's fit one warp,
// hyq's and iiwa14's P do not fit their packed matrices and take the level passes): at 128 threads
// a state (the chains on the first warp, the other three on d tau/d qd), at the automatic shape,
// at 32 (one warp: the chains, then d tau/d qd) and at 48 (not whole warps: every thread through
// the chains' steps, synced as the group).
TEST(CudaRobotSpecificKernel, LeanKernelByChainsMatchesTheGenericOne) {
  expect_builds_match_the_generic_kernel(
      {{true, true, 128, true}, {true, true, 0, true}, {true, true, 32, true}, {true, true, 48, true}});
}

// The same with M^-1's columns by the tree's blocks (block_tree_columns; device/block_tree_columns.hpp,
// whose host test has them bit-identical to the generic columns): the same shapes.
TEST(CudaRobotSpecificKernel, LeanKernelByTreeColumnsMatchesTheGenericOne) {
  expect_builds_match_the_generic_kernel({{true, true, 128, true, true},
                                          {true, true, 0, true, true},
                                          {true, true, 32, true, true},
                                          {true, true, 48, true, true}});
}

// The compact build with its full working set (block_lean: false).
TEST(CudaRobotSpecificKernel, CompactKernelMatchesTheGenericOne) {
  expect_builds_match_the_generic_kernel({{true, false, 0}});
}

// The dense build (block_compact: false).
TEST(CudaRobotSpecificKernel, DenseKernelMatchesTheGenericOne) {
  expect_builds_match_the_generic_kernel({{false, false, 0}});
}

// Instances of one model share one compilation (the process's memory cache).
TEST(CudaRobotSpecificKernel, SecondInstanceOfAModelReusesTheCompilation) {
  const Model model = testing::load_embedded("panda");
  std::unique_ptr<CudaInstance> first, second;
  if (Status s = CudaInstance::create(model, 0, first); !s) GTEST_SKIP() << "no GPU: " << s.message();
  if (Status s = first->specialize(""); !s) {
    if (s.code() == StatusCode::kUnavailable) GTEST_SKIP() << "no NVRTC: " << s.message();
    FAIL() << s.message();
  }
  ASSERT_TRUE(CudaInstance::create(model, 0, second));
  ASSERT_TRUE(second->specialize(""));
  EXPECT_THAT(second->kernel_description(), HasSubstr("f64: memory cache"));
  EXPECT_THAT(second->kernel_description(), HasSubstr("f32: memory cache"));
}

}  // namespace
}  // namespace rbdgrad::cuda
