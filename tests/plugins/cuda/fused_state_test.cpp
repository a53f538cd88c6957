// Tests for plugins/cuda/device/fused_state.hpp compiled as plain C++ and run on the CPU: the math
// of the fused kernel against the core library, for every embedded robot (and a random tree with
// prismatic joints), f64 and f32, every output case, both input kinds, external forces and a
// caller-supplied M^-1. Runs everywhere, GPU or not; cuda_plugin_test.cpp runs the same code on a GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/core_reference.hpp"
#include "cuda_test_support.hpp"
#include "device/fused_state.hpp"
#include "flat_model.hpp"

namespace rbdgrad::testing {
namespace {

constexpr std::size_t kStates = 50;

// Runs evaluate_state on the host for every state of `a` (one workspace slot, stride 1).
template <class S>
std::vector<std::uint32_t> run_on_host(const Model& model, CudaBatch<S>& a, const OutputCase& c, bool tau_input) {
  const cuda::FlatModel<S> flat(model);
  const cuda::ModelView<S> m = flat.host_view();
  std::vector<S> scratch(cuda::WorkspaceView<S>::scalars(model.nv), S(0));
  const cuda::WorkspaceView<S> ws(scratch.data(), 0, 1, model.nv);
  const cuda::BatchPointers<S> b = a.pointers(c, tau_input);
  std::vector<std::uint32_t> status(a.n);
  for (std::size_t k = 0; k < a.n; ++k) status[k] = cuda::evaluate_state(m, ws, b, k);
  return status;
}

template <class S>
void check_robot(const std::string& robot) {
  const Model model = robot_model(robot);
  const std::vector<StateInputs> states = random_inputs(model, kStates, 99);
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kOutputCases) {
      const std::string where = robot + " " + scalar_name<S>() + " " + c.name + (tau_input ? ", tau input" : ", qdd input");
      CudaBatch<S> a(states, model.nv, tau_input);
      a.poison();
      const std::vector<std::uint32_t> status = run_on_host(model, a, c, tau_input);
      for (std::size_t k = 0; k < kStates; ++k) ASSERT_EQ(status[k], 0u) << where << " state " << k;
      const Comparison cmp = compare_with_core(model, a, c, tau_input);
      ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
      EXPECT_TRUE(cmp.within_bounds<S>()) << where << ": " << cmp.summary();
      // the errors of the first case, for the log (median/worst relative Frobenius error)
      if (&c == &kOutputCases[0]) std::printf("%s:%s\n", where.c_str(), cmp.summary().c_str());
    }
  }
}

class FusedStateOnHost : public ::testing::TestWithParam<const char*> {};

TEST_P(FusedStateOnHost, F64MatchesCore) { check_robot<double>(GetParam()); }
TEST_P(FusedStateOnHost, F32MatchesCore) { check_robot<float>(GetParam()); }

INSTANTIATE_TEST_SUITE_P(Robots, FusedStateOnHost,
                         ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq", "random_tree"),
                         [](const auto& param_info) { return std::string(param_info.param); });

}  // namespace
}  // namespace rbdgrad::testing
