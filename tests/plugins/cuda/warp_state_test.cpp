// Tests for plugins/cuda/device/warp_fused_state.hpp (the warp kernel's math: one state on a
// segment of W lanes) compiled as plain C++ and run on the CPU with one thread per lane: a shuffle
// is a write to the segment's slots, a barrier, a read of the source lane's slot and another
// barrier, which is what __shfl_sync means for code whose lanes all take part. Against the core
// library for every embedded robot and a random branching tree with prismatic joints, every output
// case the kernel takes, both input kinds, f64 and f32 batches (computed in f64); a state fails
// with the block kernel's status.
#include <gtest/gtest.h>

#include <barrier>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/core_reference.hpp"
#include "cuda_test_support.hpp"
#include "device/warp_fused_state.hpp"
#include "flat_model.hpp"

namespace rbdgrad::testing {
namespace {

// The W threads of one segment and what they exchange.
struct HostSegment {
  explicit HostSegment(int width) : barrier(width), slots(static_cast<std::size_t>(width)) {}
  std::barrier<> barrier;
  std::vector<double> slots;  // every exchanged value (double or int) fits a double exactly
  bool out_of_range = false;
};

// The lanes interface of device/warp_lanes.hpp on host threads.
struct HostLanes {
  int lane = 0;
  int segment = 0;
  HostSegment* seg = nullptr;
  std::uint64_t first_state = 0;  // the state this segment computes (a warp of one segment)

  template <class T>
  T shfl(T x, int from) const {
    seg->slots[static_cast<std::size_t>(lane)] = static_cast<double>(x);
    seg->barrier.arrive_and_wait();
    if (from < 0 || from >= static_cast<int>(seg->slots.size())) {
      seg->out_of_range = true;
      from = 0;
    }
    const T y = static_cast<T>(seg->slots[static_cast<std::size_t>(from)]);
    seg->barrier.arrive_and_wait();
    return y;
  }
  void sync() const { seg->barrier.arrive_and_wait(); }
  void stamp() const {}
  template <class S, class IO>
  void write_states(const S* from, IO* out, int count) const {
    if (out == nullptr) return;
    for (int e = lane; e < count; e += static_cast<int>(seg->slots.size()))
      out[first_state * static_cast<std::uint64_t>(count) + static_cast<std::uint64_t>(e)] = static_cast<IO>(from[e]);
  }
  bool any(bool p) const {
    seg->slots[static_cast<std::size_t>(lane)] = p ? 1.0 : 0.0;
    seg->barrier.arrive_and_wait();
    bool found = false;
    for (double s : seg->slots) found = found || s != 0.0;
    seg->barrier.arrive_and_wait();
    return found;
  }
};

// Every state of the batch, one after the other, on one segment of W host threads.
template <int W, class IO>
std::vector<std::uint32_t> run_warp_on_host(const Model& model, CudaBatch<IO>& a, const OutputCase& c, bool tau_input) {
  const cuda::FlatModel<double> flat(model);
  const cuda::ModelView<double> m(flat.host_view());
  std::vector<double> shared(cuda::WarpShared<W>::kScalars, poison<double>());
  cuda::BatchPointers<IO> b = a.pointers(c, tau_input);
  std::vector<std::uint32_t> status(a.n, 0xffffffffu);
  b.status = status.data();
  HostSegment seg(W);
  std::vector<std::thread> lanes;
  for (int lane = 0; lane < W; ++lane)
    lanes.emplace_back([&, lane] {
      HostLanes g{lane, 0, &seg};
      for (std::size_t k = 0; k < a.n; ++k) {
        g.first_state = k;
        cuda::warp_evaluate_state<W, double, IO, cuda::block_stages::kPerBatch>(m, shared.data(), b, k, true, g);
      }
    });
  for (std::thread& t : lanes) t.join();
  EXPECT_FALSE(seg.out_of_range) << "a shuffle read a lane outside the segment";
  return status;
}

template <class IO>
std::vector<std::uint32_t> run_warp(const Model& model, CudaBatch<IO>& a, const OutputCase& c, bool tau_input) {
  return cuda::warp_segment_width(model.nv) == 8 ? run_warp_on_host<8>(model, a, c, tau_input)
                                                 : run_warp_on_host<16>(model, a, c, tau_input);
}

template <class IO>
void check_robot(const std::string& robot, std::size_t states_per_case) {
  const Model model = robot_model(robot);
  ASSERT_LE(model.nv, cuda::kMaxWarpNv) << robot;
  const std::vector<StateInputs> states = random_inputs(model, states_per_case, 17);
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kBlockCases) {
      CudaBatch<IO> a(states, model.nv, tau_input);
      ASSERT_TRUE(cuda::warp_kernel_supports(a.pointers(c, tau_input), model.nv)) << c.name;
      const std::string where = robot + " " + scalar_name<IO>() + " batch, " + c.name +
                                (tau_input ? ", tau input" : ", qdd input");
      a.poison();
      const std::vector<std::uint32_t> status = run_warp(model, a, c, tau_input);
      for (std::size_t k = 0; k < states.size(); ++k) ASSERT_EQ(status[k], 0u) << where << " state " << k;
      const Comparison cmp = compare_with_core(model, a, c, tau_input);
      ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
      EXPECT_TRUE(cmp.within_bounds<IO>()) << where << ": " << cmp.summary();
      if (&c == &kBlockCases[1]) std::printf("%s:%s\n", where.c_str(), cmp.summary().c_str());
    }
  }
}

class WarpStateOnHost : public ::testing::TestWithParam<const char*> {};

TEST_P(WarpStateOnHost, F64MatchesCore) { check_robot<double>(GetParam(), 4); }
TEST_P(WarpStateOnHost, F32BatchComputedInF64MatchesCore) { check_robot<float>(GetParam(), 2); }

// every embedded robot the kernel takes (talos_reduced, 32 joints, stays on the block kernel) and
// a branching tree of 12 joints with prismatic ones
INSTANTIATE_TEST_SUITE_P(Robots, WarpStateOnHost, ::testing::Values("iiwa14", "panda", "hyq", "random_tree"),
                         [](const auto& param_info) { return std::string(param_info.param); });

TEST(WarpKernel, SegmentWidthHoldsTheModel) {
  EXPECT_EQ(cuda::warp_segment_width(1), 8);
  EXPECT_EQ(cuda::warp_segment_width(7), 8);
  EXPECT_EQ(cuda::warp_segment_width(8), 8);
  EXPECT_EQ(cuda::warp_segment_width(9), 16);
  EXPECT_EQ(cuda::warp_segment_width(16), 16);
  EXPECT_EQ(cuda::warp_segment_width(17), 0);
}

TEST(WarpKernel, TakesTheBlockKernelsRequestsUpTo16Joints) {
  const Model model = robot_model("iiwa14");
  CudaBatch<double> a(random_inputs(model, 1, 5), model.nv, true);
  const cuda::BatchPointers<double> gradient = a.pointers(kBlockCases[0], true);
  EXPECT_TRUE(cuda::warp_kernel_supports(gradient, 16));
  EXPECT_FALSE(cuda::warp_kernel_supports(gradient, 17));
  const OutputCase tau{"tau and d qdd", kOutputDqdd | RBDGRAD_OUTPUT_TAU, false, false};
  EXPECT_FALSE(cuda::warp_kernel_supports(a.pointers(tau, true), 7));
}

// A mass matrix that is not positive definite, and a state that is not finite, fail as on the
// block kernel (and so as on the CPU): the same reason, algorithm and joint.
TEST(WarpStateOnHost, FailingStatesHaveTheBlockKernelsStatus) {
  Model model = robot_model("iiwa14");
  std::vector<StateInputs> states = random_inputs(model, 3, 3);
  states[1].qd[2] = std::nan("");
  const int last = model.nv - 1;
  model.mass[static_cast<std::size_t>(last)] = 0;
  model.inertia_com[static_cast<std::size_t>(last)].setZero();
  for (const Model& m : {robot_model("iiwa14"), model}) {
    const OutputCase& c = kBlockCases[1];
    CudaBatch<double> warp(states, m.nv, true), block(states, m.nv, true);
    const std::vector<std::uint32_t> status = run_warp(m, warp, c, true);
    const cuda::FlatModel<double> flat(m);
    const cuda::ModelView<double> view(flat.host_view());
    std::vector<double> shared(cuda::BlockWorkspace<double>::scalars(m.nv, false), 0.0);
    const cuda::BlockWorkspace<double> w(shared.data(), m.nv, false);
    cuda::BatchPointers<double> b = block.pointers(c, true);
    std::vector<std::uint32_t> expected(states.size(), 0xffffffffu);
    b.status = expected.data();
    for (std::size_t k = 0; k < states.size(); ++k) {
      cuda::block_load_inputs(m.nv, w, b, k, cuda::ThreadGroup{});
      cuda::block_evaluate_state(view, w, b, k, true, cuda::ThreadGroup{});
    }
    EXPECT_NE(expected[1], 0u);
    EXPECT_EQ(status, expected) << (&m == &model ? "zero mass" : "NaN velocity");
  }
}

}  // namespace
}  // namespace rbdgrad::testing
