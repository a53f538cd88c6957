// Tests for plugins/cuda/device/warp_fused_state.hpp (the warp kernel's math: one state on a
// segment of W lanes) compiled as plain C++ and run on the CPU with one thread per lane: a shuffle
// is a write to the segment's slots, a barrier, a read of the source lane's slot and another
// barrier, which is what __shfl_sync means for code whose lanes all take part. Against the core
// library for every embedded robot and a random branching tree with prismatic joints, every output
// case the kernel takes, both input kinds, f64 and f32 batches (computed in f64); a state fails
// with the block kernel's status.
#include <gtest/gtest.h>

#include <algorithm>
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

// The threads of one warp, kSegments segments of W lanes, and what they exchange.
struct HostWarp {
  explicit HostWarp(int threads) : barrier(threads), slots(static_cast<std::size_t>(threads)) {}
  std::barrier<> barrier;
  std::vector<double> slots;  // every exchanged value (double or int) fits a double exactly
  bool out_of_range = false;
};

// The lanes interface of device/warp_lanes.hpp on host threads: lane `lane` of segment `segment`.
template <int W, int Segments>
struct HostLanes {
  static constexpr int kSegments = Segments;
  int lane = 0;
  int segment = 0;
  HostWarp* warp = nullptr;
  std::uint64_t first_state = 0;
  int states_in_warp = 0;
  int shared_stride = 0;

  std::size_t slot(int l) const { return static_cast<std::size_t>(segment * W + l); }
  template <class T>
  T shfl(T x, int from) const {
    warp->slots[slot(lane)] = static_cast<double>(x);
    warp->barrier.arrive_and_wait();
    if (from < 0 || from >= W) {
      warp->out_of_range = true;
      from = 0;
    }
    const T y = static_cast<T>(warp->slots[slot(from)]);
    warp->barrier.arrive_and_wait();
    return y;
  }
  void sync() const { warp->barrier.arrive_and_wait(); }
  // B = A B (W x W, row-major) for this segment's state: each lane a column, between barriers
  template <class S>
  void product(const S* A, S* B) const {
    sync();
    cuda::lane_column_product<W>(A, B, lane);
    sync();
  }
  // each lane its own column, between barriers
  cuda::TreeRows tree(cuda::TreeRows keep) const { return keep; }
  template <class Up, class Down, class S>
  void tree_product(Up up, Down down, cuda::TreeRows keep, const S* rows, int stride, S* out) const {
    sync();
    cuda::lane_tree_column<W>(up, down, rows, stride, keep, out, lane);
    sync();
  }
  void stamp() const {}
  template <class S>
  S* warp_shared(S* region) const {
    return region - segment * shared_stride;
  }
  unsigned or_warp(unsigned bits) const {
    warp->slots[slot(lane)] = static_cast<double>(bits);
    warp->barrier.arrive_and_wait();
    unsigned all = 0;
    for (int t = 0; t < W * Segments; ++t) all |= static_cast<unsigned>(warp->slots[static_cast<std::size_t>(t)]);
    warp->barrier.arrive_and_wait();
    return all;
  }
  template <class S, class IO>
  void write_warp(const S* staged, IO* out, int count) const {
    if (out == nullptr) return;
    IO* to = out + first_state * static_cast<std::uint64_t>(count);
    for (int e = segment * W + lane; e < states_in_warp * count; e += W * Segments) to[e] = static_cast<IO>(staged[e]);
  }
};

// The batch's states on warps of `Segments` segments of W host threads each, one warp after the
// other, as the kernel's entry lays them out (warp_kernel.cu): the last warp's segments past the
// end of the batch compute its last state and write nothing. View: the generic ModelView, or a
// FixedSizeModelView of the model's sizes (the kernel compiled for the robot).
template <int W, int Segments, class IO, class View = cuda::ModelView<double>>
std::vector<std::uint32_t> run_warps_on_host(const Model& model, CudaBatch<IO>& a, const OutputCase& c,
                                             bool tau_input, bool early_outputs) {
  const cuda::FlatModel<double> flat(model);
  const View m(flat.host_view());
  constexpr int kStride = cuda::WarpShared<W>::kScalars;
  std::vector<double> shared(static_cast<std::size_t>(cuda::WarpShared<W>::warp_scalars(Segments)), poison<double>());
  cuda::BatchPointers<IO> b = a.pointers(c, tau_input);
  std::vector<std::uint32_t> status(a.n, 0xffffffffu);
  b.status = status.data();
  HostWarp warp(W * Segments);
  std::vector<std::thread> threads;
  for (int t = 0; t < W * Segments; ++t)
    threads.emplace_back([&, t] {
      HostLanes<W, Segments> g;
      g.lane = t % W;
      g.segment = t / W;
      g.warp = &warp;
      g.shared_stride = kStride;
      for (std::size_t first = 0; first < a.n; first += Segments) {
        const std::size_t k = first + static_cast<std::size_t>(g.segment);
        g.first_state = first;
        g.states_in_warp = static_cast<int>(std::min<std::size_t>(a.n - first, Segments));
        cuda::warp_evaluate_state<W, double, IO, cuda::block_stages::kPerBatch>(
            m, shared.data() + g.segment * kStride, b, k < a.n ? k : a.n - 1, k < a.n, early_outputs, g);
      }
    });
  for (std::thread& t : threads) t.join();
  EXPECT_FALSE(warp.out_of_range) << "a shuffle read a lane outside the segment";
  return status;
}

// One segment per warp (the fewest threads); full_warps: 32 / W segments, as on the GPU.
// early_outputs: the kernel's first outputs written before d tau/d q (large batches), else at the
// end.
template <class IO>
std::vector<std::uint32_t> run_warp(const Model& model, CudaBatch<IO>& a, const OutputCase& c, bool tau_input,
                                    bool early_outputs, bool full_warps = false) {
  const bool e = early_outputs;
  if (cuda::warp_segment_width(model.nv) == 8)
    return full_warps ? run_warps_on_host<8, 4>(model, a, c, tau_input, e) : run_warps_on_host<8, 1>(model, a, c, tau_input, e);
  return full_warps ? run_warps_on_host<16, 2>(model, a, c, tau_input, e)
                    : run_warps_on_host<16, 1>(model, a, c, tau_input, e);
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
      // the two places of the first outputs, taking turns over the cases
      const bool early = ((&c - kBlockCases) % 2 == 0) == tau_input;
      const std::string where = robot + " " + scalar_name<IO>() + " batch, " + c.name +
                                (tau_input ? ", tau input" : ", qdd input") + (early ? ", early outputs" : "");
      a.poison();
      const std::vector<std::uint32_t> status = run_warp(model, a, c, tau_input, early);
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

// Whole warps (4 states of iiwa14, 2 of hyq per warp) and batches that end inside a warp: the
// warp's states write their outputs together, each where it belongs.
TEST(WarpStateOnHost, WholeWarpsWriteEachStatesOutputs) {
  for (const char* robot : {"iiwa14", "hyq"}) {
    const Model model = robot_model(robot);
    for (const std::size_t n : {1u, 5u, 7u}) {
      const std::vector<StateInputs> states = random_inputs(model, n, 23);
      const OutputCase& c = kBlockCases[1];
      CudaBatch<double> a(states, model.nv, true);
      a.poison();
      const bool early = n != 5;
      const std::vector<std::uint32_t> status = run_warp(model, a, c, true, early, true);
      const std::string where =
          std::string(robot) + ", " + std::to_string(n) + " states" + (early ? ", early outputs" : "");
      for (std::size_t k = 0; k < n; ++k) ASSERT_EQ(status[k], 0u) << where << " state " << k;
      const Comparison cmp = compare_with_core(model, a, c, true);
      ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
      EXPECT_TRUE(cmp.within_bounds<double>()) << where << ": " << cmp.summary();
    }
  }
}

// The model types of the kernel compiled for iiwa14, a chain, and hyq, four legs of three: the
// sizes and the tree as constants (kernel_source.cpp writes them; kernel_source_test.cpp checks
// the same constants). Branch8Tree: a random tree of 8 joints with branches (parents -1 0 0 2 0 4
// 5 4), where M^-1 is factorized in every lane as for iiwa14, but M's upper triangle also has
// entries whose row is in another branch.
using IiwaTree = cuda::FixedTreeModelView<double, 7, 7, 0x6543210ull, 0x6666666ull>;
using HyqTree = cuda::FixedTreeModelView<double, 12, 3, 0xba0870540210ull, 0xbbb888555222ull>;
using Branch8Tree = cuda::FixedTreeModelView<double, 8, 4, 0x56513110ull, 0x76673317ull>;
Model branch8_model() { return random_model(19, 8, TreeShape::kBranching); }

template <class Fixed>
void expect_fixed_tree_is(const Model& model) {
  const cuda::FlatModel<double> flat(model);
  const Fixed view(flat.host_view());
  ASSERT_EQ(cuda::FixedSizes<Fixed>::nv, model.nv) << model.name;
  ASSERT_EQ(cuda::FixedSizes<Fixed>::levels, model.max_depth()) << model.name;
  for (int i = 0; i < model.nv; ++i) {
    EXPECT_EQ(cuda::FixedTree<Fixed>::parent(view, i), model.parent[i]) << model.name << " joint " << i;
    EXPECT_EQ(cuda::FixedTree<Fixed>::subtree_end(view, i), model.subtree_end[i]) << model.name << " joint " << i;
  }
}

TEST(WarpStateOnHost, FixedTreeIsTheModelsTree) {
  static_assert(cuda::FixedTree<IiwaTree>::known && !cuda::FixedTree<cuda::ModelView<double>>::known);
  expect_fixed_tree_is<IiwaTree>(robot_model("iiwa14"));
  expect_fixed_tree_is<HyqTree>(robot_model("hyq"));
  expect_fixed_tree_is<Branch8Tree>(branch8_model());
}

// The code the kernel compiled for the robot runs (the joint count, depth and tree as constants:
// fixed loop trip counts, no loads of the tree) on iiwa14, hyq and the branched tree of 8 joints:
// the same results.
TEST(WarpStateOnHost, RobotSizedCodeMatchesCore) {
  const Model iiwa = robot_model("iiwa14"), hyq = robot_model("hyq"), branch8 = branch8_model();
  for (const bool early : {false, true}) {
    for (const Model* model : {&iiwa, &hyq, &branch8}) {
      const std::vector<StateInputs> states = random_inputs(*model, 5, 31);
      const OutputCase& c = kBlockCases[1];
      CudaBatch<double> a(states, model->nv, true);
      a.poison();
      const std::vector<std::uint32_t> status =
          model == &iiwa  ? run_warps_on_host<8, 4, double, IiwaTree>(*model, a, c, true, early)
          : model == &hyq ? run_warps_on_host<16, 2, double, HyqTree>(*model, a, c, true, early)
                          : run_warps_on_host<8, 4, double, Branch8Tree>(*model, a, c, true, early);
      const std::string where = model->name + (early ? ", early outputs" : "");
      for (std::size_t k = 0; k < states.size(); ++k) ASSERT_EQ(status[k], 0u) << where << " state " << k;
      const Comparison cmp = compare_with_core(*model, a, c, true);
      ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
      EXPECT_TRUE(cmp.within_bounds<double>()) << where << ": " << cmp.summary();
    }
  }
}

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
  const Model plain = robot_model("iiwa14");
  // one state a segment, and the three in one warp (a failing state flags only its own); the code
  // for any robot, and the code compiled for iiwa14 (M^-1 by a factorization in every lane)
  for (const bool robot_sized : {false, true}) {
    for (const bool full_warps : {false, true}) {
      for (const Model* m : {&plain, static_cast<const Model*>(&model)}) {
        const bool zero_mass = m == &model;
        const OutputCase& c = kBlockCases[1];
        CudaBatch<double> warp(states, m->nv, true), block(states, m->nv, true);
        const std::vector<std::uint32_t> status =
            !robot_sized ? run_warp(*m, warp, c, true, zero_mass, full_warps)
            : full_warps ? run_warps_on_host<8, 4, double, IiwaTree>(*m, warp, c, true, zero_mass)
                         : run_warps_on_host<8, 1, double, IiwaTree>(*m, warp, c, true, zero_mass);
        const cuda::FlatModel<double> flat(*m);
        const cuda::ModelView<double> view(flat.host_view());
        std::vector<double> shared(cuda::BlockWorkspace<double>::scalars(m->nv, false), 0.0);
        const cuda::BlockWorkspace<double> w(shared.data(), m->nv, false);
        cuda::BatchPointers<double> b = block.pointers(c, true);
        std::vector<std::uint32_t> expected(states.size(), 0xffffffffu);
        b.status = expected.data();
        for (std::size_t k = 0; k < states.size(); ++k) {
          cuda::block_load_inputs(m->nv, w, b, k, cuda::ThreadGroup{});
          cuda::block_evaluate_state(view, w, b, k, true, cuda::ThreadGroup{});
        }
        const std::string where = std::string(zero_mass ? "zero mass" : "NaN velocity") + (full_warps ? ", whole warps" : "") +
                                  (robot_sized ? ", robot-sized code" : "");
        EXPECT_NE(expected[1], 0u) << where;
        if (!zero_mass) {
          EXPECT_EQ(expected[0], 0u) << where;  // the NaN flags its own state only
        }
        EXPECT_EQ(status, expected) << where;
      }
    }
  }
}

}  // namespace
}  // namespace rbdgrad::testing
