// Tests for plugins/cuda/device/block_fused_state.hpp (the block kernel's math: one state on a
// group of threads) compiled as plain C++ and run on the CPU by one thread: against
// the core library for every embedded robot and a random tree with prismatic joints, f64 and f32,
// both input kinds, every output case the block kernel takes. Each case also runs with the items
// of every pass in reverse order and as the GPU's group of 256 threads: the results must not
// change, which shows that no item of a pass depends on another (on the GPU, such a dependency
// would be a race) and that the items a group's size shapes cover the same entries. The compact
// kernel's packed matrices (block_kernel_entry.hpp) give the same bits as the dense ones; its lean
// working set (block_workspace.hpp: B by its symmetric part and h, arrays placed by lifetime),
// another rounding, matches the core as closely.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/core_reference.hpp"
#include "cuda_test_support.hpp"
#include "device/block_fused_state.hpp"
#include "flat_model.hpp"
#include "host_tree_view.hpp"

namespace rbdgrad::testing {
namespace {

constexpr std::size_t kStates = 40;

// Scalars after a state's working set that no pass may write (checked after every state).
constexpr std::size_t kGuardScalars = 64;

// Model: ModelView<S> as the generic kernel sees the robot, or FixedSizeModelView<S, nv, levels>
// as the kernel compiled for it at load does. kPacked: the compact kernel's matrices, its working
// set sized as the kernel sizes it (block_state_scalars). kLean: the lean working set. reverse:
// each pass's items in reverse order. threads: the group's size, which shapes a pass's items (row
// segments) and, for the tree fixed, how M^-1 is found (block_tree_chains.hpp, from two whole
// warps); 0: one thread, or 256 reversed.
template <class S, class Model = cuda::ModelView<S>, int kStages = cuda::block_stages::kPerBatch, bool kPacked = false,
          bool kLean = false>
std::vector<std::uint32_t> run_block_on_host(const rbdgrad::Model& model, CudaBatch<S>& a, const OutputCase& c,
                                             bool tau_input, bool reverse, int threads = 0) {
  const cuda::FlatModel<S> flat(model);
  const Model m(flat.host_view());
  const bool with_aba = cuda::block_uses_aba<S>(tau_input);
  cuda::BatchPointers<S> b = a.pointers(c, tau_input);
  const std::size_t scalars = cuda::block_state_scalars(flat.host_view(), tau_input, b.minv != nullptr, kPacked, kLean);
  std::vector<S> shared(scalars + kGuardScalars, poison<S>());
  const cuda::BlockWorkspace<S> w(shared.data(), model.nv, with_aba,
                                  cuda::block_matrices(model.nv, flat.matrix_scalars, kPacked, b.minv != nullptr), kLean);
  std::vector<std::uint32_t> status(a.n, 0xffffffffu);
  b.status = status.data();
  cuda::ThreadGroup g;
  g.reverse = reverse;
  // reversed, as the GPU's group of threads, which gives a pass more items (row segments)
  g.size = threads > 0 ? threads : reverse ? 256 : 1;
  for (std::size_t k = 0; k < a.n; ++k) {
    cuda::block_load_inputs(m.nv, w, b, k, g);
    cuda::block_evaluate_state<S, Model, S, kStages, kPacked, kLean>(m, w, b, k, true, g);
    for (std::size_t e = scalars; e < shared.size(); ++e)
      EXPECT_EQ(0, std::memcmp(&shared[e], &shared.back(), sizeof(S))) << "state " << k << " wrote past its working set";
  }
  return status;
}

// Whether two batches' outputs are the same bits (the first that is not, otherwise)
template <class S>
::testing::AssertionResult same_outputs(const CudaBatch<S>& x, const CudaBatch<S>& y) {
  for (int f = 0; f < 8; ++f)
    if (std::memcmp(x.out[f].data(), y.out[f].data(), x.out[f].size() * sizeof(S)) != 0)
      return ::testing::AssertionFailure() << "output " << Comparison::plugin_output_name(f) << " differs";
  return ::testing::AssertionSuccess();
}

template <class S>
void check_robot(const std::string& robot) {
  const Model model = robot_model(robot);
  const std::vector<StateInputs> states = random_inputs(model, kStates, 7);
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kBlockCases) {
      CudaBatch<S> a(states, model.nv, tau_input);
      ASSERT_TRUE(cuda::block_kernel_supports(a.pointers(c, tau_input))) << c.name;
      const std::string where = robot + " " + scalar_name<S>() + " " + c.name + (tau_input ? ", tau input" : ", qdd input");
      a.poison();
      const std::vector<std::uint32_t> status = run_block_on_host(model, a, c, tau_input, false);
      for (std::size_t k = 0; k < kStates; ++k) ASSERT_EQ(status[k], 0u) << where << " state " << k;
      const Comparison cmp = compare_with_core(model, a, c, tau_input);
      ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
      EXPECT_TRUE(cmp.within_bounds<S>()) << where << ": " << cmp.summary();
      if (&c == &kBlockCases[1]) std::printf("%s:%s\n", where.c_str(), cmp.summary().c_str());

      CudaBatch<S> reversed(states, model.nv, tau_input);
      reversed.poison();
      run_block_on_host(model, reversed, c, tau_input, true);
      ASSERT_TRUE(same_outputs(a, reversed)) << where << ": with the items in reverse order, as 256 threads";

      // packed by the roots' blocks, in reverse order as 256 threads: the same bits
      CudaBatch<S> packed(states, model.nv, tau_input);
      packed.poison();
      const std::vector<std::uint32_t> packed_status =
          run_block_on_host<S, cuda::ModelView<S>, cuda::block_stages::kPerBatch, true>(model, packed, c, tau_input, true);
      ASSERT_EQ(status, packed_status) << where << ", packed";
      ASSERT_TRUE(same_outputs(a, packed)) << where << ": with the matrices packed";

      // the lean working set, packed: against the core, and in reverse order as 128 threads (its
      // shape for eight talos_reduced states an SM) the same bits
      constexpr int kPerBatch = cuda::block_stages::kPerBatch;
      CudaBatch<S> lean(states, model.nv, tau_input), lean_reversed(states, model.nv, tau_input);
      lean.poison();
      lean_reversed.poison();
      const auto lean_status = run_block_on_host<S, cuda::ModelView<S>, kPerBatch, true, true>(model, lean, c, tau_input, false);
      ASSERT_EQ(status, lean_status) << where << ", lean";
      const Comparison lean_cmp = compare_with_core(model, lean, c, tau_input);
      ASSERT_TRUE(lean_cmp.message.empty()) << where << ", lean: " << lean_cmp.message;
      EXPECT_TRUE(lean_cmp.within_bounds<S>()) << where << ", lean: " << lean_cmp.summary();
      run_block_on_host<S, cuda::ModelView<S>, kPerBatch, true, true>(model, lean_reversed, c, tau_input, true, 128);
      ASSERT_TRUE(same_outputs(lean, lean_reversed))
          << where << ": the lean working set with the items in reverse order, as 128 threads";
    }
  }
}

TEST(BlockStateOnHost, DividerIsExactForEveryIndexOfAPass) {
  for (int n = 1; n <= cuda::kMaxBlockNv; ++n) {
    const cuda::block::Divider d(n);
    for (int t = 0; t < 4 * n * n + 64 * n; ++t) {
      ASSERT_EQ(d.quotient(t), t / n) << t << " / " << n;
      ASSERT_EQ(d.remainder(t), t % n) << t << " % " << n;
    }
  }
}

// The robot-specific kernel (kernel_source.cpp) fixes nv and the tree's depth at compile time:
// the same code, so the same results bit for bit (this test builds without FMA contraction, so
// the constant folding cannot change a rounding either).
template <class S, int NV, int LEVELS>
void check_fixed_sizes(const std::string& robot) {
  const Model model = robot_model(robot);
  ASSERT_EQ(model.nv, NV) << robot;
  ASSERT_EQ(model.max_depth(), LEVELS) << robot;
  const std::vector<StateInputs> states = random_inputs(model, 8, 11);
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kBlockCases) {
      CudaBatch<S> run_time(states, model.nv, tau_input), fixed(states, model.nv, tau_input);
      run_time.poison();
      fixed.poison();
      const auto s1 = run_block_on_host<S>(model, run_time, c, tau_input, false);
      const auto s2 = run_block_on_host<S, cuda::FixedSizeModelView<S, NV, LEVELS>>(model, fixed, c, tau_input, false);
      const std::string where = robot + " " + scalar_name<S>() + " " + c.name + (tau_input ? ", tau input" : ", qdd input");
      ASSERT_EQ(s1, s2) << where;
      ASSERT_TRUE(same_outputs(run_time, fixed)) << where << ": with the sizes fixed";
      // and the compact kernel compiled for the robot: sizes fixed, matrices packed
      CudaBatch<S> compact(states, model.nv, tau_input);
      compact.poison();
      const auto s3 = run_block_on_host<S, cuda::FixedSizeModelView<S, NV, LEVELS>, cuda::block_stages::kPerBatch, true>(
          model, compact, c, tau_input, false);
      ASSERT_EQ(s1, s3) << where << ", compact";
      ASSERT_TRUE(same_outputs(run_time, compact)) << where << ": with the sizes fixed, packed";
      // and the lean working set, run-time sizes against fixed ones
      constexpr int kPerBatch = cuda::block_stages::kPerBatch;
      CudaBatch<S> lean(states, model.nv, tau_input), lean_fixed(states, model.nv, tau_input);
      lean.poison();
      lean_fixed.poison();
      const auto s4 = run_block_on_host<S, cuda::ModelView<S>, kPerBatch, true, true>(model, lean, c, tau_input, false);
      const auto s5 = run_block_on_host<S, cuda::FixedSizeModelView<S, NV, LEVELS>, kPerBatch, true, true>(
          model, lean_fixed, c, tau_input, false);
      ASSERT_EQ(s4, s5) << where << ", lean";
      ASSERT_TRUE(same_outputs(lean, lean_fixed)) << where << ": the lean working set with the sizes fixed";
    }
  }
}

TEST(BlockStateOnHost, FixedSizesGiveTheSameBits) {
  check_fixed_sizes<double, 7, 7>("iiwa14");
  check_fixed_sizes<float, 7, 7>("iiwa14");
  check_fixed_sizes<double, 12, 3>("hyq");
  check_fixed_sizes<float, 12, 3>("hyq");
  check_fixed_sizes<double, 32, 10>("talos_reduced");
}

// The lean kernel compiled for a robot with its tree fixed (TreeModelView): the passes that
// unroll over the tree sum in another order, so the results match the core as closely, not bit
// for bit; in reverse order, the same bits. As 128 threads (its shape for large launches), M^-1
// by the tree's chains on one warp (block_tree_chains.hpp); as one thread, by the generic passes.
template <class S, int NV, int LEVELS>
void check_fixed_tree(const std::string& robot) {
  const Model model = robot_model(robot);
  ASSERT_EQ(model.nv, NV) << robot;
  ASSERT_EQ(model.max_depth(), LEVELS) << robot;
  const std::vector<StateInputs> states = random_inputs(model, kStates, 13);
  constexpr int kPerBatch = cuda::block_stages::kPerBatch;
  using Tree = cuda::HostTreeView<S, NV, LEVELS>;
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kBlockCases) {
      const std::string where = robot + " " + scalar_name<S>() + " " + c.name + (tau_input ? ", tau input" : ", qdd input");
      for (const int threads : {128, 1}) {
        const std::string shape = ", tree fixed, " + std::to_string(threads) + " threads";
        CudaBatch<S> tree(states, model.nv, tau_input), reversed(states, model.nv, tau_input);
        tree.poison();
        reversed.poison();
        const auto status = run_block_on_host<S, Tree, kPerBatch, true, true>(model, tree, c, tau_input, false, threads);
        for (std::size_t k = 0; k < kStates; ++k) ASSERT_EQ(status[k], 0u) << where << shape << " state " << k;
        const Comparison cmp = compare_with_core(model, tree, c, tau_input);
        ASSERT_TRUE(cmp.message.empty()) << where << shape << ": " << cmp.message;
        EXPECT_TRUE(cmp.within_bounds<S>()) << where << shape << ": " << cmp.summary();
        run_block_on_host<S, Tree, kPerBatch, true, true>(model, reversed, c, tau_input, true, threads);
        ASSERT_TRUE(same_outputs(tree, reversed)) << where << shape << ": the items in reverse order";
      }
    }
  }
}

TEST(BlockStateOnHost, FixedTreeMatchesTheCore) {
  check_fixed_tree<double, 32, 10>("talos_reduced");
  check_fixed_tree<float, 32, 10>("talos_reduced");
  check_fixed_tree<double, 12, 3>("hyq");
  check_fixed_tree<double, 7, 7>("iiwa14");
  // f32 with the articulated-body pass's arrays after the matrices, an odd joint count: a pair
  // read (scalar_pairs.hpp) and the 6-vectors read whole must still start at even offsets
  check_fixed_tree<float, 7, 7>("iiwa14");
}

// The blocks the inversion and the products with M^-1 keep to (ModelView::root_of): each joint's
// root is a root and holds the joint in its subtree, and the roots' subtrees cover the joints in
// order. The humanoid's fixed base splits it into its two legs and its torso with arms and head.
TEST(BlockStateOnHost, RootsSplitTheJointsIntoBlocks) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq", "random_tree"}) {
    const Model model = robot_model(robot);
    const cuda::FlatModel<double> flat(model);
    const cuda::ModelView<double> m = flat.host_view();
    std::vector<int> block_sizes;
    for (int i = 0; i < m.nv; ++i) {
      const int root = m.root_of[i];
      ASSERT_EQ(m.parent[root], -1) << robot << " joint " << i;
      ASSERT_TRUE(m.contains(root, i)) << robot << " joint " << i;
      if (root == i) block_sizes.push_back(m.subtree_end[i] - i);
      else ASSERT_EQ(root, m.root_of[i - 1]) << robot << " joint " << i << ": a block is a contiguous range";
    }
    int covered = 0;
    for (int size : block_sizes) covered += size;
    EXPECT_EQ(covered, m.nv) << robot;
    if (std::string(robot) == "talos_reduced") {
      EXPECT_EQ(block_sizes, (std::vector<int>{6, 6, 20}));
    }
    if (std::string(robot) == "iiwa14") {
      EXPECT_EQ(block_sizes, (std::vector<int>{7}));
    }
  }
}

// The compact kernel's packing (ModelView::matrix_row): the blocks' entries one after the other,
// each stored once, nothing between; a tree with one root packs nothing (row i at i nv).
TEST(BlockStateOnHost, MatrixRowsPackTheBlocks) {
  for (const char* robot : {"iiwa14", "talos_reduced", "hyq", "random_tree", "wide_tree"}) {
    const Model model = robot_model(robot);
    const cuda::FlatModel<double> flat(model);
    const cuda::ModelView<double> m = flat.host_view();
    ASSERT_EQ(m.matrix_scalars, flat.matrix_scalars) << robot;
    std::vector<int> seen(static_cast<std::size_t>(m.matrix_scalars), 0);
    for (int i = 0; i < m.nv; ++i)
      for (int j = m.root_of[i]; j < m.subtree_end[m.root_of[i]]; ++j) {
        const int at = m.matrix_row[i] + j;
        ASSERT_GE(at, 0) << robot << " (" << i << ", " << j << ")";
        ASSERT_LT(at, m.matrix_scalars) << robot << " (" << i << ", " << j << ")";
        ++seen[static_cast<std::size_t>(at)];
      }
    for (std::size_t e = 0; e < seen.size(); ++e) ASSERT_EQ(seen[e], 1) << robot << " packed entry " << e;
    if (std::string(robot) == "talos_reduced") {
      EXPECT_EQ(m.matrix_scalars, 6 * 6 + 6 * 6 + 20 * 20);
    }
    if (std::string(robot) == "iiwa14") {
      EXPECT_EQ(m.matrix_scalars, 49);
      for (int i = 0; i < m.nv; ++i) EXPECT_EQ(m.matrix_row[i], 7 * i);
    }
  }
}

// The lean working set's 6-vector arrays and M^-1 computed in it start at even offsets, and its
// states are an even number of scalars apart: the block kernel reads them two scalars a load
// (scalar_pairs.hpp), which needs a pair's first scalar aligned to two. For odd and even nv, with
// and without the caller's M^-1 and the f32 articulated-body pass's arrays. (The host runs also
// abort on a misaligned pair, but they run one state a buffer.)
TEST(BlockStateOnHost, LeanLayoutAlignsThePairs) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq", "random_tree", "wide_tree"}) {
    const Model model = robot_model(robot);
    const cuda::FlatModel<double> flat(model);
    for (const bool minv_supplied : {false, true})
      for (const bool with_aba : {false, true}) {
        const cuda::BlockMatrices matrices = cuda::block_matrices(model.nv, flat.matrix_scalars, true, minv_supplied);
        const std::size_t scalars = cuda::BlockWorkspace<double>::scalars(model.nv, with_aba, matrices, true);
        const std::string where = std::string(robot) + (minv_supplied ? ", the caller's M^-1" : "") +
                                  (with_aba ? ", with the articulated-body pass" : "");
        EXPECT_EQ(scalars % 2, 0u) << where << ": " << scalars << " scalars a state";
        std::vector<double> shared(scalars);
        const cuda::BlockWorkspace<double> w(shared.data(), model.nv, with_aba, matrices, true);
        const std::pair<const char*, const double*> paired[] = {
            {"axis", w.axis}, {"alpha", w.alpha}, {"beta", w.beta}, {"E", w.E},      {"Dq", w.Dq},
            {"Ic_S", w.Ic_S}, {"Bc_t_S", w.Bc_t_S}, {"IA_S", w.IA_S}, {"M^-1", minv_supplied ? nullptr : w.M}};
        for (const auto& [name, at] : paired) {
          if (at == nullptr) continue;
          EXPECT_EQ((at - shared.data()) % 2, 0) << where << ": " << name << " at " << (at - shared.data());
        }
      }
  }
}

TEST(BlockStateOnHost, FixedDividerIsExact) {
  const cuda::block::FixedDivider<7> d7;
  const cuda::block::FixedDivider<32> d32;
  for (int t = 0; t < 4 * 32 * 32 + 64 * 32; ++t) {
    ASSERT_EQ(d7.quotient(t), t / 7);
    ASSERT_EQ(d7.remainder(t), t % 7);
    ASSERT_EQ(d32.quotient(t), t / 32);
    ASSERT_EQ(d32.remainder(t), t % 32);
  }
}

TEST(BlockStateOnHost, TakesOnlyTheGradientRequests) {
  const Model model = robot_model("iiwa14");
  CudaBatch<double> a(random_inputs(model, 1, 5), model.nv, true);
  // with a caller's M^-1, the MINV output is M^-1(q) computed (plugin_api.h): the one-thread kernel's
  const OutputCase supplied{"M^-1 with supplied M^-1", kOutputDqdd | RBDGRAD_OUTPUT_MINV, false, true};
  const OutputCase tau{"tau and d qdd", kOutputDqdd | RBDGRAD_OUTPUT_TAU, false, false};
  const OutputCase qdd{"qdd alone", RBDGRAD_OUTPUT_QDD, false, false};
  for (const OutputCase& c : {supplied, tau, qdd}) EXPECT_FALSE(cuda::block_kernel_supports(a.pointers(c, true))) << c.name;
}

// A scene's kernel (issue 8) has its stages fixed at compile time (block_stages): the same code as
// the kernel that decides per batch, less what the stages exclude, so the same bits for what it
// computes.
template <class S, int kStages>
void check_fixed_stages(const std::string& robot, const OutputCase& c) {
  const Model model = robot_model(robot);
  const std::vector<StateInputs> states = random_inputs(model, 6, 13);
  for (const bool tau_input : {true, false}) {
    CudaBatch<S> per_batch(states, model.nv, tau_input), fixed(states, model.nv, tau_input);
    per_batch.poison();
    fixed.poison();
    const auto s1 = run_block_on_host<S>(model, per_batch, c, tau_input, false);
    const auto s2 = run_block_on_host<S, cuda::ModelView<S>, kStages>(model, fixed, c, tau_input, true);
    const std::string where = robot + " " + scalar_name<S>() + " stages " + std::to_string(kStages) + " " + c.name +
                              (tau_input ? ", tau input" : ", qdd input");
    ASSERT_EQ(s1, s2) << where;
    for (std::size_t k = 0; k < states.size(); ++k) ASSERT_EQ(s1[k], 0u) << where << " state " << k;
    ASSERT_TRUE(same_outputs(per_batch, fixed)) << where << ": with the stages fixed";
    const Comparison cmp = compare_with_core(model, fixed, c, tau_input);
    ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
    EXPECT_TRUE(cmp.within_bounds<S>()) << where << ": " << cmp.summary();
    // the compact kernel's lean working set, per batch and with the stages fixed: the same bits
    CudaBatch<S> lean(states, model.nv, tau_input), lean_fixed(states, model.nv, tau_input);
    lean.poison();
    lean_fixed.poison();
    const auto s3 =
        run_block_on_host<S, cuda::ModelView<S>, cuda::block_stages::kPerBatch, true, true>(model, lean, c, tau_input, false);
    const auto s4 = run_block_on_host<S, cuda::ModelView<S>, kStages, true, true>(model, lean_fixed, c, tau_input, true);
    ASSERT_EQ(s3, s4) << where << ", lean";
    ASSERT_TRUE(same_outputs(lean, lean_fixed)) << where << ": the lean working set with the stages fixed";
    const Comparison lean_cmp = compare_with_core(model, lean_fixed, c, tau_input);
    ASSERT_TRUE(lean_cmp.message.empty()) << where << ", lean: " << lean_cmp.message;
    EXPECT_TRUE(lean_cmp.within_bounds<S>()) << where << ", lean: " << lean_cmp.summary();
  }
}

TEST(BlockStateOnHost, FixedStagesGiveTheSameBits) {
  namespace st = cuda::block_stages;
  const OutputCase dq{"d qdd/d q", RBDGRAD_OUTPUT_DQDD_DQ, false, false};
  const OutputCase dqd_forces{"qdd and d qdd/d qd, external forces", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQD, true,
                              false};
  const OutputCase both_supplied{"d qdd with supplied M^-1", kOutputDqdd, false, true};
  const OutputCase dq_supplied{"d qdd/d q with supplied M^-1, external forces", RBDGRAD_OUTPUT_DQDD_DQ, true, true};
  for (const char* robot : {"iiwa14", "hyq"}) {
    check_fixed_stages<double, st::kDq>(robot, dq);
    check_fixed_stages<float, st::kDq>(robot, dq);
    check_fixed_stages<double, st::kDqd>(robot, dqd_forces);
    check_fixed_stages<float, st::kDqd>(robot, dqd_forces);
    check_fixed_stages<double, st::kDq | st::kDqd | st::kMinvSupplied>(robot, both_supplied);
    check_fixed_stages<double, st::kDq | st::kMinvSupplied>(robot, dq_supplied);
    check_fixed_stages<float, st::kDq | st::kMinvSupplied>(robot, dq_supplied);
  }
}

// A stage a batch does not ask for is not computed: without d qdd/d q, the matrix that d tau/d qd
// and d tau/d q share (BlockWorkspace) still holds d tau/d qd after the state, the core's, where the
// d/dq stage would have left d tau/d q.
TEST(BlockStateOnHost, SkippedStagesLeaveTheirArraysUntouched) {
  const Model model = robot_model("iiwa14");
  const cuda::FlatModel<double> flat(model);
  const cuda::ModelView<double> m(flat.host_view());
  CudaBatch<double> a(random_inputs(model, 1, 3), model.nv, true);
  std::vector<double> shared(cuda::BlockWorkspace<double>::scalars(model.nv, false), poison<double>());
  const cuda::BlockWorkspace<double> w(shared.data(), model.nv, false);
  const OutputCase dqd{"d qdd/d qd", RBDGRAD_OUTPUT_DQDD_DQD, false, false};
  cuda::BatchPointers<double> b = a.pointers(dqd, true);
  std::uint32_t status = 1;
  b.status = &status;
  cuda::ThreadGroup g;
  cuda::block_load_inputs(m.nv, w, b, 0, g);
  cuda::block_evaluate_state(m, w, b, 0, true, g);
  ASSERT_EQ(status, 0u);
  Workspace ws(model);
  std::map<std::uint32_t, Eigen::MatrixXd> ref;
  ASSERT_TRUE(reference_state(model, ws, reference_inputs(a, 0, dqd), true, RBDGRAD_OUTPUT_DTAU_DQD | RBDGRAD_OUTPUT_DTAU_DQ, ref));
  const Eigen::MatrixXd& dtau_dqd = ref[RBDGRAD_OUTPUT_DTAU_DQD];
  ASSERT_GT((ref[RBDGRAD_OUTPUT_DTAU_DQ] - dtau_dqd).norm(), 1e-3 * dtau_dqd.norm()) << "the two would not tell";
  for (int r = 0; r < model.nv; ++r)
    for (int c = 0; c < model.nv; ++c)
      EXPECT_NEAR(w.dtau_dqd[r * model.nv + c], dtau_dqd(r, c), 1e-12 * (1 + std::abs(dtau_dqd(r, c))))
          << "(" << r << ", " << c << "): the d/dq stage ran for a batch without d qdd/d q";

  // the lean working set takes beta's first part with the body forces, for the d/dq stage only
  const cuda::BlockMatrices matrices = cuda::block_matrices(model.nv, flat.matrix_scalars, true, false);
  std::vector<double> lean_shared(cuda::BlockWorkspace<double>::scalars(model.nv, false, matrices, true),
                                  poison<double>());
  const cuda::BlockWorkspace<double> lean(lean_shared.data(), model.nv, false, matrices, true);
  cuda::block_load_inputs(m.nv, lean, b, 0, g);
  cuda::block_evaluate_state<double, cuda::ModelView<double>, double, cuda::block_stages::kPerBatch, true, true>(
      m, lean, b, 0, true, g);
  ASSERT_EQ(status, 0u);
  for (int e = 0; e < 6 * model.nv; ++e)
    EXPECT_EQ(0, std::memcmp(&lean.beta[e], &lean_shared.back(), sizeof(double)))
        << "beta[" << e << "]: the lean working set took beta for a batch without d qdd/d q";
}

class BlockStateOnHost : public ::testing::TestWithParam<const char*> {};

TEST_P(BlockStateOnHost, F64MatchesCore) { check_robot<double>(GetParam()); }
TEST_P(BlockStateOnHost, F32MatchesCore) { check_robot<float>(GetParam()); }

INSTANTIATE_TEST_SUITE_P(Robots, BlockStateOnHost,
                         ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq", "random_tree", "wide_tree"),
                         [](const auto& param_info) { return std::string(param_info.param); });

// A mass matrix that is not positive definite fails the state with the core's reason and joint
// (the first in the core's order, last joint first): on a tree, two massless leaves, the deepest
// one and the last one (one leaf on a chain).
TEST(BlockStateOnHost, ZeroMassFailsWithTheCoresReason) {
  for (const char* robot : {"iiwa14", "talos_reduced", "wide_tree"}) {
    Model model = robot_model(robot);
    int deepest = -1;
    for (int i = 0; i < model.nv; ++i) {
      const auto at = static_cast<std::size_t>(i);
      const bool leaf = model.subtree_end[at] == i + 1;
      if (leaf && (deepest < 0 || model.depth[at] > model.depth[static_cast<std::size_t>(deepest)])) deepest = i;
    }
    for (const int i : {deepest, model.nv - 1}) {
      model.mass[static_cast<std::size_t>(i)] = 0;
      model.inertia_com[static_cast<std::size_t>(i)].setZero();
    }
    if (std::string(robot) == "talos_reduced") {
      ASSERT_LT(deepest, model.nv - 1) << "two different leaves";
    }
    const std::vector<StateInputs> states = random_inputs(robot_model(robot), 2, 3);
    CudaBatch<double> a(states, model.nv, true);
    const OutputCase& c = kBlockCases[0];
    const std::vector<std::uint32_t> status = run_block_on_host(model, a, c, true, false);
    CudaBatch<double> lean(states, model.nv, true);
    const std::vector<std::uint32_t> lean_status =
        run_block_on_host<double, cuda::ModelView<double>, cuda::block_stages::kPerBatch, true, true>(model, lean, c, true,
                                                                                                    false);
    EXPECT_EQ(status, lean_status) << robot << ": the lean working set's statuses";
    // as 128 threads (row segments: the pivot's thread among a row's flags it)
    CudaBatch<double> lean_segments(states, model.nv, true);
    EXPECT_EQ(status, (run_block_on_host<double, cuda::ModelView<double>, cuda::block_stages::kPerBatch, true, true>(
                          model, lean_segments, c, true, true, 128)))
        << robot << ": the lean working set's statuses as 128 threads";
    const cuda::FlatModel<double> flat(model);
    std::vector<double> scratch(cuda::WorkspaceView<double>::scalars(model.nv), 0.0);
    const cuda::WorkspaceView<double> ws(scratch.data(), 0, 1, model.nv);
    const cuda::BatchPointers<double> b = a.pointers(c, true);
    for (std::size_t k = 0; k < 2; ++k) {
      EXPECT_EQ(cuda::status_reason(status[k]), cuda::Reason::kMassNotPositive) << robot << " state " << k;
      EXPECT_EQ(status[k], cuda::evaluate_state(flat.host_view(), ws, b, k))
          << robot << " state " << k << ": the one-thread kernel's status";
    }
  }
}

}  // namespace
}  // namespace rbdgrad::testing
