// Tests for plugins/fpga/host/latency_model.cpp: a small case counted by hand, the structure of the
// estimate (phases sum to the total, monotonic in nv and N, exactly inverse in the clock,
// topology, the columns that run), the defaults against the kernel's pragmas, and the refusals.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../../support/test_models.hpp"
#include "host/latency_model.hpp"
#include "kernel/axi_layout.hpp"

namespace rbdgrad::fpga {
namespace {

// A model with only what the latency model reads: nv and parent.
Model topology(std::vector<int> parent) {
  Model m;
  m.nv = static_cast<int>(parent.size());
  m.parent = std::move(parent);
  return m;
}

LatencyEstimate estimate(const Model& model, const KernelTiming& timing, std::size_t n_states,
                         InputKind input = InputKind::kQdd) {
  LatencyEstimate e;
  const Status s = estimate_latency(model, timing, n_states, input, e);
  EXPECT_TRUE(s.is_ok()) << s.to_string();
  return e;
}

// The same with the column datapaths that run (the mode's kModeNoDq, kModeNoDqd).
LatencyEstimate estimate_columns(const Model& model, const KernelTiming& timing, unsigned columns,
                                 InputKind input = InputKind::kQdd) {
  LatencyEstimate e;
  const Status s = estimate_latency(model, timing, 1, input, columns, e);
  EXPECT_TRUE(s.is_ok()) << s.to_string();
  return e;
}

// Latencies that differ from each other, so that a miscounted operator shows.
KernelTiming hand_timing() {
  KernelTiming t;
  t.multiplier_cycles = 5;  // m
  t.adder_cycles = 2;       // a
  t.memory_read_cycles = 3;  // r
  t.loop_iteration_overhead_cycles = 1;  // o
  t.column_unroll = 2;
  t.joint_transform_ii = 1;
  t.axi_port_bits = 32;
  t.axi_burst_efficiency = 1.0;
  t.axi_latency_cycles = 10;
  t.clock_mhz = 100.0;
  t.host_round_trip_us = 5.0;
  t.pcie_gbytes_per_s = 1.0;
  return t;
}

// A 2-joint chain counted by hand from gradient_kernel.hpp (m = 5, a = 2, r = 3, o = 1, U = 2).
// Blocks: 3-term tree m + 2a = 9, cross m + a = 7, transform_motion cross + a + rotate = 18,
//   transform_force_back rotate + cross + a = 18, cross_force cross + a = 9, mul66 m + 3a = 11.
// Forward body (ready times): X vp, X ap 3 + 18 = 21; v 23; a 23 + 5 + 2 = 30; h 23 + 11 = 34;
//   I a 41; v x* h 34 + 9 = 43; f max(41, 43) + 2 = 45.
// Forward column, joint 1: X dv, X da 21; dv 23; da 30; I da 41; I dv 34; dv x* h 32;
//   v x* I dv 43; df = sum of 32, 41, 43: max(41 + 2, 43) + 2 = 45.
// Forward column, root: no parent terms: read 3; dv 5; da 12; I da 23; I dv 16; c1 14; c2 25;
//   df max(23 + 2, 25) + 2 = 27.
// 2 nv = 4 columns, U = 2: 2 passes. Forward: root 1 + 45 + 2 (27 + 1) = 102, joint 1
//   1 + 45 + 2 (45 + 1) = 138: 240.
// Backward column, joint 1: X^T df and X^T (S x* f) 3 + 18 = 21; df_par + both: max(21 + 2, 21) + 2
//   = 25; root: the read, 3. Force into the parent: 3 + 18 + 2 = 23. Backward: joint 1
//   1 + 3 (tau) + 2 (25 + 1) + 23 = 79, root 1 + 3 + 2 (3 + 1) = 12: 91.
// joint_transforms (II 1): 1 + (3 + 5 + 2) + 1 = 12. qdd copied: 2 (3 + 1) = 8.
// -M^-1 dc/du: dot of 2 terms 2 (3 + 5 + 2 + 1) = 22; row 22 + 2 (round) + 2 (negate) + 1 = 27;
//   pass 1 + 2 x 27 = 55; 2 passes: 110.
// Total 12 + 8 + 240 + 91 + 110 = 461.
TEST(FpgaLatencyModel, TwoJointChainByHand) {
  const LatencyEstimate e = estimate(topology({-1, 0}), hand_timing(), 3);
  EXPECT_EQ(e.phases.joint_transforms, 12);
  EXPECT_EQ(e.phases.qdd, 8);
  EXPECT_EQ(e.phases.forward_sweep, 240);
  EXPECT_EQ(e.phases.backward_sweep, 91);
  EXPECT_EQ(e.phases.minv_product, 110);
  EXPECT_EQ(e.cycles_per_gradient, 461);
  // Idealised: one pass, the body alongside the columns: forward root 1 + max(45, 27 + 1) = 46,
  // joint 1 1 + max(45, 45 + 1) = 47; backward root 1 + 3 + max(3 + 1, 0) = 8, joint 1
  // 1 + 3 + max(25 + 1, 23) = 30; -M^-1 dc/du 1 + 2 x 27 = 55. 12 + 8 + 93 + 38 + 55 = 206.
  EXPECT_EQ(e.ideal_cycles_per_gradient, 206);
  // AXI: in 5 nv + nv^2 = 14 words, out nv + 2 nv^2 + 1 = 11, one word a beat, latency 10 each way:
  // 45 a state; the robot's 1 + 50 nv + 3 = 104 words: 114. 3 states: 114 + 3 (45 + 461) = 1632.
  EXPECT_EQ(e.transfer_cycles_per_state, 45);
  EXPECT_EQ(e.robot_transfer_cycles, 114);
  EXPECT_EQ(e.batch_cycles, 1632);
  EXPECT_DOUBLE_EQ(e.gradient_us, 4.61);
  EXPECT_DOUBLE_EQ(e.kernel_us, 16.32);
  // PCIe: 3 x 25 words x 4 bytes = 300 bytes at 1 GB/s = 0.3 us; plus the 5 us round trip
  EXPECT_NEAR(e.host_transfer_us, 0.3, 1e-12);
  EXPECT_NEAR(e.batch_us, 5 + 0.3 + 16.32, 1e-12);
}

// From tau: zeros 2 (0 + 1) = 2; the first pass, the bias alone (rnea_gradient(..., 0u): no column
// pass): forward root 1 + 45 = 46, joint 1 46: 92; backward joint 1 1 + 3 + 23 = 27, root 1 + 3 =
// 4: 31; bias 2 (3 + 2 + 1) = 12; qdd rows 2 (22 + 2 (round) + 1) = 50: 187 in the qdd phase;
// 12 + 187 + 240 + 91 + 110 = 640. (Before the kernel's first pass dropped its columns, it ran
// them: 240 + 91 for it, 395 and 848.)
TEST(FpgaLatencyModel, TwoJointChainFromTauByHand) {
  const LatencyEstimate e = estimate(topology({-1, 0}), hand_timing(), 1, InputKind::kTau);
  EXPECT_EQ(e.phases.qdd, 187);
  EXPECT_EQ(e.phases.forward_sweep, 240);
  EXPECT_EQ(e.cycles_per_gradient, 640);
}

// One derivative: the loops over columns run nv = 2 of the 4 columns, ceil(2 / U) = 1 pass
// instead of 2. Forward: root 1 + 45 + (27 + 1) = 74, joint 1 1 + 45 + (45 + 1) = 92: 166.
// Backward: joint 1 1 + 3 + (25 + 1) + 23 = 53, root 1 + 3 + (3 + 1) = 8: 61. -M^-1 dc/du: one pass,
// 1 + 2 x 27 = 55. 12 + 8 + 166 + 61 + 55 = 302. d/dq and d/dqd run the same datapath (its range is
// the mode's, known at run time). No column (qdd alone): forward 92, backward 31, no product:
// 12 + 8 + 92 + 31 = 143, and each pass of the three loops costs (461 - 143) / 2 = 159 = 302 - 143.
// Idealised, one derivative is one pass as both are: 206; none: 143.
TEST(FpgaLatencyModel, TwoJointChainWithOneDerivativeByHand) {
  const Model chain = topology({-1, 0});
  for (unsigned columns : {kColumnsDq, kColumnsDqd}) {
    const LatencyEstimate e = estimate_columns(chain, hand_timing(), columns);
    EXPECT_EQ(e.column_passes, 1) << columns;
    EXPECT_EQ(e.phases.joint_transforms, 12) << columns;
    EXPECT_EQ(e.phases.qdd, 8) << columns;
    EXPECT_EQ(e.phases.forward_sweep, 166) << columns;
    EXPECT_EQ(e.phases.backward_sweep, 61) << columns;
    EXPECT_EQ(e.phases.minv_product, 55) << columns;
    EXPECT_EQ(e.cycles_per_gradient, 302) << columns;
    EXPECT_EQ(e.ideal_cycles_per_gradient, 206) << columns;
    EXPECT_EQ(e.transfer_cycles_per_state, 45) << columns;  // the same words: zeros for the others
  }
  const LatencyEstimate none = estimate_columns(chain, hand_timing(), 0);
  EXPECT_EQ(none.column_passes, 0);
  EXPECT_EQ(none.phases.forward_sweep, 92);
  EXPECT_EQ(none.phases.backward_sweep, 31);
  EXPECT_EQ(none.phases.minv_product, 0);
  EXPECT_EQ(none.cycles_per_gradient, 143);
  EXPECT_EQ(none.ideal_cycles_per_gradient, 143);
  EXPECT_EQ(estimate_columns(chain, hand_timing(), kAllColumns).column_passes, 2);
}

// Loops without a pragma pipelined: dot of 2 terms (2 - 1) 2 + (3 + 5 + 2) + 1 = 13; row
// 13 + 4 + 1 = 18; -M^-1 dc/du 2 (1 + 2 x 18) = 74; qdd copy (2 - 1) + 3 + 1 = 5.
// 12 + 5 + 240 + 91 + 74 = 422.
TEST(FpgaLatencyModel, PipelinedUnmarkedLoopsByHand) {
  KernelTiming t = hand_timing();
  t.pipeline_unmarked_loops = true;
  const LatencyEstimate e = estimate(topology({-1, 0}), t, 1);
  EXPECT_EQ(e.phases.minv_product, 74);
  EXPECT_EQ(e.phases.qdd, 5);
  EXPECT_EQ(e.cycles_per_gradient, 422);
}

// Two roots: as written the links still run one after the other (two root links: forward 2 x 102,
// backward 2 x 12); idealised the siblings share a level: forward 46, backward 8, and
// 12 + 8 + 46 + 8 + 55 = 129 against the chain's 206.
TEST(FpgaLatencyModel, SiblingsOverlapOnlyInTheIdealisedFigure) {
  const LatencyEstimate e = estimate(topology({-1, -1}), hand_timing(), 1);
  EXPECT_EQ(e.phases.forward_sweep, 204);
  EXPECT_EQ(e.phases.backward_sweep, 24);
  EXPECT_EQ(e.ideal_cycles_per_gradient, 129);
}

TEST(FpgaLatencyModel, PhasesSumToTheTotalOnEveryRobot) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) {
    const Model model = testing::load_embedded(robot);
    for (InputKind input : {InputKind::kQdd, InputKind::kTau}) {
      const LatencyEstimate e = estimate(model, KernelTiming{}, 16, input);
      EXPECT_EQ(e.phases.total(), e.cycles_per_gradient) << robot;
      EXPECT_GT(e.phases.joint_transforms, 0) << robot;
      EXPECT_GT(e.phases.forward_sweep, 0) << robot;
      EXPECT_GT(e.phases.backward_sweep, 0) << robot;
      EXPECT_GT(e.phases.minv_product, 0) << robot;
      EXPECT_LT(e.ideal_cycles_per_gradient, e.cycles_per_gradient) << robot;
      EXPECT_EQ(e.batch_cycles, e.robot_transfer_cycles + 16 * (e.transfer_cycles_per_state + e.cycles_per_gradient));
    }
  }
}

// From tau the code runs a first RNEA pass for the bias c, without its columns (the second pass
// writes every column it computes): the qdd phase holds the sweeps of a pass with no column, plus
// M^-1 (tau - c), and is the same whichever columns the second pass runs. It costs less than the
// second pass's sweeps with both columns.
TEST(FpgaLatencyModel, TauInputRunsAFirstPassWithoutColumns) {
  const Model model = testing::load_embedded("iiwa14");
  const LatencyEstimate qdd = estimate(model, KernelTiming{}, 1, InputKind::kQdd);
  const LatencyEstimate tau = estimate(model, KernelTiming{}, 1, InputKind::kTau);
  const LatencyEstimate no_columns = estimate_columns(model, KernelTiming{}, 0, InputKind::kQdd);
  EXPECT_EQ(tau.phases.forward_sweep, qdd.phases.forward_sweep);
  EXPECT_EQ(tau.phases.backward_sweep, qdd.phases.backward_sweep);
  EXPECT_GT(tau.phases.qdd, no_columns.phases.forward_sweep + no_columns.phases.backward_sweep);
  EXPECT_LT(tau.phases.qdd, qdd.phases.forward_sweep + qdd.phases.backward_sweep);
  for (unsigned columns : {0u, kColumnsDq, kColumnsDqd})
    EXPECT_EQ(estimate_columns(model, KernelTiming{}, columns, InputKind::kTau).phases.qdd, tau.phases.qdd) << columns;
}

// The columns change only the three column loops' pass count, ceil(k / U) for k columns: each of
// their phases is its columnless part plus that many equal passes, and nothing else moves. So one
// derivative (nv columns) costs ceil(nv / U) / ceil(2 nv / U) of both columns' share of those loops,
// d/dq and d/dqd alike, and the saving is the passes it leaves out.
TEST(FpgaLatencyModel, OneDerivativeRunsFewerColumnPasses) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) {
    const Model model = testing::load_embedded(robot);
    const std::int64_t u = KernelTiming{}.column_unroll;
    const std::int64_t p_both = (2 * model.nv + u - 1) / u, p_one = (model.nv + u - 1) / u;
    for (InputKind input : {InputKind::kQdd, InputKind::kTau}) {
      const LatencyEstimate both = estimate_columns(model, KernelTiming{}, kAllColumns, input);
      const LatencyEstimate dq = estimate_columns(model, KernelTiming{}, kColumnsDq, input);
      const LatencyEstimate dqd = estimate_columns(model, KernelTiming{}, kColumnsDqd, input);
      const LatencyEstimate none = estimate_columns(model, KernelTiming{}, 0, input);
      const LatencyEstimate full = estimate(model, KernelTiming{}, 1, input);
      EXPECT_EQ(both.cycles_per_gradient, full.cycles_per_gradient) << robot;  // the default: both
      EXPECT_EQ(both.column_passes, p_both) << robot;
      EXPECT_EQ(dq.column_passes, p_one) << robot;
      EXPECT_EQ(none.column_passes, 0) << robot;
      EXPECT_EQ(dq.phases.total(), dq.cycles_per_gradient) << robot;
      EXPECT_EQ(dqd.phases.total(), dqd.cycles_per_gradient) << robot;
      EXPECT_LT(dq.cycles_per_gradient, both.cycles_per_gradient) << robot;
      EXPECT_GT(dq.cycles_per_gradient, none.cycles_per_gradient) << robot;
      for (const LatencyEstimate* e : {&dqd, &none}) {  // outside the column loops, nothing moves
        EXPECT_EQ(e->phases.joint_transforms, both.phases.joint_transforms) << robot;
        EXPECT_EQ(e->phases.qdd, both.phases.qdd) << robot;
        EXPECT_EQ(e->transfer_cycles_per_state, both.transfer_cycles_per_state) << robot;
      }
      const std::pair<std::int64_t PhaseCycles::*, const char*> column_phases[] = {
          {&PhaseCycles::forward_sweep, "forward"},
          {&PhaseCycles::backward_sweep, "backward"},
          {&PhaseCycles::minv_product, "-M^-1 dc/du"}};
      for (const auto& [phase, name] : column_phases) {
        EXPECT_EQ(dq.phases.*phase, dqd.phases.*phase) << robot << " " << name;
        const std::int64_t share_both = both.phases.*phase - none.phases.*phase;
        const std::int64_t share_one = dq.phases.*phase - none.phases.*phase;
        EXPECT_GT(share_one, 0) << robot << " " << name;
        EXPECT_EQ(share_both % p_both, 0) << robot << " " << name;  // equal passes
        EXPECT_EQ(share_both * p_one, share_one * p_both) << robot << " " << name;
      }
      const std::int64_t share = both.cycles_per_gradient - none.cycles_per_gradient;
      EXPECT_EQ((both.cycles_per_gradient - dq.cycles_per_gradient) * p_both, share * (p_both - p_one)) << robot;
      // idealised: every column its own datapath, one pass for one derivative as for both
      EXPECT_EQ(dq.ideal_cycles_per_gradient, both.ideal_cycles_per_gradient) << robot;
      EXPECT_LT(none.ideal_cycles_per_gradient, dq.ideal_cycles_per_gradient) << robot;
    }
  }
}

// The saving is in passes: with a datapath per column (U >= 2 nv) both columns are one pass, and
// one derivative is no cheaper; with U = nv it is one pass of two. The batch follows the gradient.
TEST(FpgaLatencyModel, TheSavingIsInPasses) {
  const Model model = testing::load_embedded("iiwa14");  // 14 columns
  KernelTiming t;
  t.column_unroll = 14;
  EXPECT_EQ(estimate_columns(model, t, kColumnsDq).cycles_per_gradient,
            estimate_columns(model, t, kAllColumns).cycles_per_gradient);
  t.column_unroll = 7;
  const LatencyEstimate both = estimate_columns(model, t, kAllColumns), dq = estimate_columns(model, t, kColumnsDq),
                        none = estimate_columns(model, t, 0);
  EXPECT_EQ(both.cycles_per_gradient - dq.cycles_per_gradient, dq.cycles_per_gradient - none.cycles_per_gradient);

  LatencyEstimate b, d;
  ASSERT_TRUE(estimate_latency(model, KernelTiming{}, 64, InputKind::kTau, kAllColumns, b).is_ok());
  ASSERT_TRUE(estimate_latency(model, KernelTiming{}, 64, InputKind::kTau, kColumnsDqd, d).is_ok());
  EXPECT_EQ(b.batch_cycles - d.batch_cycles, 64 * (b.cycles_per_gradient - d.cycles_per_gradient));
  EXPECT_DOUBLE_EQ(b.host_transfer_us, d.host_transfer_us);
  EXPECT_LT(d.batch_us, b.batch_us);
}

TEST(FpgaLatencyModel, MonotonicInJointsAndStates) {
  for (InputKind input : {InputKind::kQdd, InputKind::kTau}) {
    std::int64_t previous = 0, previous_transfer = 0;
    for (int nv = 1; nv <= kDeviceMaxNv; ++nv) {
      const Model chain = testing::random_model(7u + static_cast<unsigned>(nv), nv, testing::TreeShape::kChain);
      const LatencyEstimate e = estimate(chain, KernelTiming{}, 1, input);
      EXPECT_GT(e.cycles_per_gradient, previous) << "nv " << nv;
      EXPECT_GT(e.transfer_cycles_per_state, previous_transfer) << "nv " << nv;
      previous = e.cycles_per_gradient;
      previous_transfer = e.transfer_cycles_per_state;
    }
  }
  const Model model = testing::load_embedded("iiwa14");
  double previous_us = 0;
  for (std::size_t n : {1u, 2u, 16u, 32u, 64u, 128u, 1024u}) {
    const LatencyEstimate e = estimate(model, KernelTiming{}, n);
    EXPECT_GT(e.batch_us, previous_us) << n << " states";
    previous_us = e.batch_us;
  }
}

// Cycles do not depend on the clock; the device's time is cycles / clock, exactly. The host's
// round trip and PCIe copies do not scale.
TEST(FpgaLatencyModel, DeviceTimeIsExactlyInverseInTheClock) {
  const Model model = testing::load_embedded("hyq");
  KernelTiming slow;
  slow.clock_mhz = 55.6;
  KernelTiming fast = slow;
  fast.clock_mhz = 4 * 55.6;
  const LatencyEstimate a = estimate(model, slow, 64), b = estimate(model, fast, 64);
  EXPECT_EQ(a.cycles_per_gradient, b.cycles_per_gradient);
  EXPECT_EQ(a.batch_cycles, b.batch_cycles);
  EXPECT_DOUBLE_EQ(a.gradient_us, 4 * b.gradient_us);
  EXPECT_DOUBLE_EQ(a.ideal_gradient_us, 4 * b.ideal_gradient_us);
  EXPECT_DOUBLE_EQ(a.kernel_us, 4 * b.kernel_us);
  EXPECT_DOUBLE_EQ(a.host_transfer_us, b.host_transfer_us);
  EXPECT_NEAR(a.batch_us - slow.host_round_trip_us - a.host_transfer_us, a.kernel_us, 1e-9);
}

// More columns side by side: fewer passes, down to one when every column has its own datapath.
TEST(FpgaLatencyModel, UnrollFactorAndPortWidth) {
  const Model model = testing::load_embedded("iiwa14");  // 14 columns
  KernelTiming t;
  std::int64_t previous = estimate(model, t, 1).cycles_per_gradient;
  for (int u : {4, 7, 14}) {
    t.column_unroll = u;
    const std::int64_t cycles = estimate(model, t, 1).cycles_per_gradient;
    EXPECT_LT(cycles, previous) << "U = " << u;
    previous = cycles;
  }
  t.column_unroll = 64;  // beyond 2 nv: still one pass
  EXPECT_EQ(estimate(model, t, 1).cycles_per_gradient, previous);

  // iiwa14: 84 words in, 106 out; 512-bit beats carry 16 words: 6 and 7 beats; at half
  // efficiency twice the beats
  KernelTiming axi;
  axi.axi_latency_cycles = 0;
  EXPECT_EQ(estimate(model, axi, 1).transfer_cycles_per_state, 84 + 106);
  axi.axi_port_bits = 512;
  EXPECT_EQ(estimate(model, axi, 1).transfer_cycles_per_state, 6 + 7);
  axi.axi_burst_efficiency = 0.5;
  EXPECT_EQ(estimate(model, axi, 1).transfer_cycles_per_state, 12 + 14);
}

// The defaults are the kernel's pragmas: three column loops with UNROLL factor = U and
// joint_transforms with PIPELINE II = 1. A change there must come here too.
TEST(FpgaLatencyModel, DefaultsFollowTheKernelPragmas) {
  const std::string path = std::string(RBDGRAD_TEST_DATA_DIR) + "/../../plugins/fpga/kernel/gradient_kernel.hpp";
  std::ifstream file(path);
  ASSERT_TRUE(file) << path;
  std::stringstream text;
  text << file.rdbuf();
  const std::string source = text.str();
  const std::regex unroll(R"(HLS UNROLL factor = (\d+))"), pipeline(R"(HLS PIPELINE II = (\d+))");
  int unrolled = 0, pipelined = 0;
  for (std::sregex_iterator it(source.begin(), source.end(), unroll), end; it != end; ++it, ++unrolled)
    EXPECT_EQ(std::stoi((*it)[1]), kKernelColumnUnroll);
  for (std::sregex_iterator it(source.begin(), source.end(), pipeline), end; it != end; ++it, ++pipelined)
    EXPECT_EQ(std::stoi((*it)[1]), kKernelJointTransformII);
  EXPECT_EQ(unrolled, 3);   // forward sweep, backward sweep, -M^-1 dc/du
  EXPECT_EQ(pipelined, 1);  // joint_transforms
  EXPECT_EQ(KernelTiming{}.column_unroll, kKernelColumnUnroll);
  EXPECT_EQ(KernelTiming{}.joint_transform_ii, kKernelJointTransformII);
}

template <class Edit>
Status with_timing(Edit edit) {
  KernelTiming t;
  edit(t);
  LatencyEstimate e;
  return estimate_latency(topology({-1, 0}), t, 1, InputKind::kQdd, e);
}

void expect_invalid(const Status& s, const std::string& field) {
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << s.to_string();
  EXPECT_NE(s.message().find(field), std::string::npos) << s.to_string();
}

TEST(FpgaLatencyModel, RefusesTimingOutOfRange) {
  EXPECT_TRUE(check_timing(KernelTiming{}).is_ok());
  expect_invalid(with_timing([](KernelTiming& t) { t.clock_mhz = 0; }), "clock_mhz");
  expect_invalid(with_timing([](KernelTiming& t) { t.clock_mhz = -300; }), "clock_mhz");
  expect_invalid(with_timing([](KernelTiming& t) { t.clock_mhz = std::numeric_limits<double>::infinity(); }),
                 "clock_mhz");
  expect_invalid(with_timing([](KernelTiming& t) { t.clock_mhz = std::numeric_limits<double>::quiet_NaN(); }),
                 "clock_mhz");
  expect_invalid(with_timing([](KernelTiming& t) { t.multiplier_cycles = 0; }), "multiplier_cycles");
  expect_invalid(with_timing([](KernelTiming& t) { t.adder_cycles = 0; }), "adder_cycles");
  expect_invalid(with_timing([](KernelTiming& t) { t.memory_read_cycles = 0; }), "memory_read_cycles");
  expect_invalid(with_timing([](KernelTiming& t) { t.loop_iteration_overhead_cycles = -1; }),
                 "loop_iteration_overhead_cycles");
  expect_invalid(with_timing([](KernelTiming& t) { t.column_unroll = 0; }), "column_unroll");
  expect_invalid(with_timing([](KernelTiming& t) { t.joint_transform_ii = 0; }), "joint_transform_ii");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_latency_cycles = -1; }), "axi_latency_cycles");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_port_bits = 16; }), "axi_port_bits");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_port_bits = 96; }), "axi_port_bits");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_port_bits = 2048; }), "axi_port_bits");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_burst_efficiency = 0; }), "axi_burst_efficiency");
  expect_invalid(with_timing([](KernelTiming& t) { t.axi_burst_efficiency = 1.5; }), "axi_burst_efficiency");
  expect_invalid(with_timing([](KernelTiming& t) { t.host_round_trip_us = -1; }), "host_round_trip_us");
  expect_invalid(with_timing([](KernelTiming& t) { t.pcie_gbytes_per_s = 0; }), "pcie_gbytes_per_s");
}

TEST(FpgaLatencyModel, RefusesModelsAndBatchesItCannotEstimate) {
  LatencyEstimate e;
  e.cycles_per_gradient = -7;  // untouched on failure
  expect_invalid(estimate_latency(topology({-1, 0}), KernelTiming{}, 0, InputKind::kQdd, e), "at least one state");
  expect_invalid(estimate_latency(topology({}), KernelTiming{}, 1, InputKind::kQdd, e), "no moving joint");
  expect_invalid(estimate_latency(topology({-1, 1}), KernelTiming{}, 1, InputKind::kQdd, e), "parent");
  expect_invalid(estimate_latency(topology({0}), KernelTiming{}, 1, InputKind::kQdd, e), "parent");
  Model short_parent = topology({-1, 0});
  short_parent.parent.pop_back();
  expect_invalid(estimate_latency(short_parent, KernelTiming{}, 1, InputKind::kQdd, e), "parent");
  const Status too_big = estimate_latency(testing::random_model(3, kDeviceMaxNv + 1, testing::TreeShape::kChain),
                                          KernelTiming{}, 1, InputKind::kQdd, e);
  EXPECT_EQ(too_big.code(), StatusCode::kFailedPrecondition) << too_big.to_string();
  expect_invalid(estimate_latency(topology({-1, 0}), KernelTiming{}, std::numeric_limits<std::size_t>::max(),
                                  InputKind::kQdd, e),
                 "too large");
  expect_invalid(estimate_latency(topology({-1, 0}), KernelTiming{}, 1, InputKind::kQdd, 4u, e), "columns");
  EXPECT_EQ(e.cycles_per_gradient, -7);
}

}  // namespace
}  // namespace rbdgrad::fpga
