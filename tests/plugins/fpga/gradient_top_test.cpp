// The FPGA kernel's top function (plugins/fpga/kernel/gradient_top.cpp) on batches packed by the
// host (plugins/fpga/host/axi_packing.cpp): bit for bit what the templated kernel computes in
// Q16.16 for each state, the out-of-range flag per state, and the packing's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "../../support/test_models.hpp"
#include "host/axi_packing.hpp"
#include "kernel/gradient_kernel.hpp"
#include "kernel/gradient_top.hpp"
#include "kernel/robot_constants.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::fpga {
namespace {

io::StateFile reference(const std::string& robot) {
  io::StateFile file;
  std::string error;
  EXPECT_TRUE(io::read_state_file(std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl", file, error))
      << error;
  return file;
}

// The batch through the top function, and each state through fd_gradient<Q16_16> from the same
// words: the same bits, and the same overflow verdict.
void check_robot(const std::string& robot, bool tau_input) {
  const Model model = testing::load_embedded(robot);
  const io::StateFile file = reference(robot);
  const int n = model.nv;
  std::vector<DeviceWord> robot_words, in;
  std::string error;
  ASSERT_TRUE(pack_robot(model, robot_words, error)) << error;
  // states whose inputs do not fit the format are refused by the packing (a floating-point backend
  // takes them); the others go to the kernel
  std::vector<const io::StateRecord*> packed;
  int refused = 0;
  for (const io::StateRecord& r : file.states) {
    if (pack_state(n, r.at("q").data(), r.at("qd").data(), r.at(tau_input ? "tau" : "qdd").data(), r.at("Minv").data(),
                   in, error)) {
      packed.push_back(&r);
    } else {
      ++refused;
      EXPECT_NE(error.find("outside the FPGA format's range"), std::string::npos) << error;
    }
  }
  const int states = static_cast<int>(packed.size());
  std::vector<DeviceWord> out(static_cast<std::size_t>(states * AxiLayout::out_words(n)), -1);
  rbdgrad_fpga_gradient(robot_words.data(), in.data(), out.data(), states, tau_input ? 1 : 0);

  auto constants = std::make_unique<RobotConstants<Q16_16, kDeviceMaxNv>>();
  ASSERT_TRUE(robot_constants(model, *constants));
  auto scratch = std::make_unique<KernelState<Q16_16, kDeviceMaxNv>>();
  int flagged = 0;
  for (int k = 0; k < states; ++k) {
    const DeviceWord* w = in.data() + static_cast<std::size_t>(k * AxiLayout::in_words(n));
    auto field = [&](int f) {
      std::vector<Q16_16> v;
      for (int i = 0; i < (f == 5 ? n * n : n); ++i) v.push_back(Q16_16::from_raw(w[f * n + i]));
      return v;
    };
    const std::vector<Q16_16> q = field(0), s = field(1), c = field(2), qd = field(3), u = field(4), minv = field(5);
    std::vector<Q16_16> qdd(n), dq(n * n), dqd(n * n);
    const FixedOverflowScope scope;
    fd_gradient(*constants, q.data(), s.data(), c.data(), qd.data(), u.data(), tau_input, minv.data(), *scratch,
                qdd.data(), dq.data(), dqd.data());
    const DeviceWord* o = out.data() + static_cast<std::size_t>(k * AxiLayout::out_words(n));
    ASSERT_EQ(o[n + 2 * n * n], scope.overflowed() ? kStatusOverflow : kStatusOk) << robot << " state " << k;
    flagged += scope.overflowed();
    for (int e = 0; e < n * n; ++e) {
      ASSERT_EQ(o[n + e], dq[e].raw()) << robot << " state " << k << " d qdd/d q " << e;
      ASSERT_EQ(o[n + n * n + e], dqd[e].raw()) << robot << " state " << k << " d qdd/d qd " << e;
    }
    for (int i = 0; i < n; ++i) ASSERT_EQ(o[i], qdd[i].raw()) << robot << " state " << k << " qdd " << i;

    // and back to doubles: close to the reference when in range, refused when flagged
    std::vector<double> back_qdd(n), back_dq(n * n), back_dqd(n * n);
    const bool in_range = unpack_state(n, o, back_qdd.data(), back_dq.data(), back_dqd.data());
    EXPECT_EQ(in_range, !scope.overflowed());
    if (in_range) {
      const std::vector<double>& ref = packed[static_cast<std::size_t>(k)]->at("dqdd_dqd");
      double num = 0, den = 0;
      for (int e = 0; e < n * n; ++e) {
        num += (back_dqd[e] - ref[e]) * (back_dqd[e] - ref[e]);
        den += ref[e] * ref[e];
      }
      EXPECT_LE(std::sqrt(num / den), 2e-2) << robot << " state " << k;
    }
  }
  std::printf("%s %s input: %d of %zu states refused by the packing, %d of the other %d flagged out of range\n",
              robot.c_str(), tau_input ? "tau" : "qdd", refused, file.states.size(), flagged, states);
}

TEST(GradientTop, MatchesTheKernelBitForBit) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"})
    for (const bool tau_input : {false, true}) check_robot(robot, tau_input);
}

// A scene's skips (issue 8): with the d/dq or d/dqd datapaths bypassed (mode kModeNoDq,
// kModeNoDqd), the other columns and qdd are the full kernel's bits, the bypassed columns' words 0.
TEST(GradientTop, BypassedColumnsLeaveTheOthersBitForBit) {
  for (const char* robot : {"iiwa14", "hyq"}) {
    const Model model = testing::load_embedded(robot);
    const io::StateFile file = reference(robot);
    const int n = model.nv;
    std::vector<DeviceWord> robot_words, in;
    std::string error;
    ASSERT_TRUE(pack_robot(model, robot_words, error)) << error;
    int states = 0;
    for (const io::StateRecord& r : file.states)
      states += pack_state(n, r.at("q").data(), r.at("qd").data(), r.at("tau").data(), r.at("Minv").data(), in, error);
    ASSERT_GT(states, 0);
    const auto run = [&](int mode) {
      std::vector<DeviceWord> out(static_cast<std::size_t>(states * AxiLayout::out_words(n)), -1);
      rbdgrad_fpga_gradient(robot_words.data(), in.data(), out.data(), states, mode);
      return out;
    };
    const std::vector<DeviceWord> full = run(kModeTauInput);
    const std::vector<DeviceWord> no_dqd = run(kModeTauInput | kModeNoDqd), no_dq = run(kModeTauInput | kModeNoDq);
    for (int k = 0; k < states; ++k) {
      const std::size_t o = static_cast<std::size_t>(k * AxiLayout::out_words(n));
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(no_dqd[o + i], full[o + i]) << robot << " state " << k << " qdd " << i;
        ASSERT_EQ(no_dq[o + i], full[o + i]) << robot << " state " << k << " qdd " << i;
      }
      for (int e = 0; e < n * n; ++e) {
        ASSERT_EQ(no_dqd[o + n + e], full[o + n + e]) << robot << " state " << k << " d qdd/d q " << e;
        ASSERT_EQ(no_dqd[o + n + n * n + e], 0) << robot << " state " << k << " bypassed d qdd/d qd " << e;
        ASSERT_EQ(no_dq[o + n + n * n + e], full[o + n + n * n + e]) << robot << " state " << k << " d qdd/d qd " << e;
        ASSERT_EQ(no_dq[o + n + e], 0) << robot << " state " << k << " bypassed d qdd/d q " << e;
      }
      // a state the full kernel keeps in range stays in range with fewer datapaths
      if (full[o + n + 2 * n * n] == kStatusOk) {
        EXPECT_EQ(no_dqd[o + n + 2 * n * n], kStatusOk) << robot << " state " << k;
        EXPECT_EQ(no_dq[o + n + 2 * n * n], kStatusOk) << robot << " state " << k;
      }
    }
  }
}

// The top function built with its columns fixed at compile time (gradient_fixed_columns, the
// kernel that never had the other datapaths: issue 8's reference in fpga_host_bench's SkipCost)
// writes the same words as the top function with the same columns from the mode word, every word
// of every state (qdd, both column blocks with the skipped one's zeros, the status), from tau and
// from qdd.
TEST(GradientTop, FixedColumnsGiveTheModesBits) {
  for (const char* robot : {"iiwa14", "hyq"}) {
    const Model model = testing::load_embedded(robot);
    const io::StateFile file = reference(robot);
    const int n = model.nv;
    std::vector<DeviceWord> robot_words;
    std::string error;
    ASSERT_TRUE(pack_robot(model, robot_words, error)) << error;
    for (const bool tau_input : {true, false}) {
      std::vector<DeviceWord> in;
      int states = 0;
      for (const io::StateRecord& r : file.states)
        states += pack_state(n, r.at("q").data(), r.at("qd").data(), r.at(tau_input ? "tau" : "qdd").data(),
                             r.at("Minv").data(), in, error);
      ASSERT_GT(states, 0);
      const int input = tau_input ? kModeTauInput : 0;
      using Top = void (*)(const DeviceWord*, const DeviceWord*, DeviceWord*, int, int);
      const auto run = [&](Top top, int mode) {
        std::vector<DeviceWord> out(static_cast<std::size_t>(states * AxiLayout::out_words(n)), -1);
        top(robot_words.data(), in.data(), out.data(), states, mode);
        return out;
      };
      const struct {
        const char* name;
        int mode;
        Top fixed;
      } cases[] = {{"d qdd/d q only", input | kModeNoDqd, &gradient_fixed_columns<kColumnsDq>},
                   {"d qdd/d qd only", input | kModeNoDq, &gradient_fixed_columns<kColumnsDqd>},
                   {"both", input, &gradient_fixed_columns<kColumnsDq | kColumnsDqd>}};
      for (const auto& c : cases) {
        const std::vector<DeviceWord> by_mode = run(&rbdgrad_fpga_gradient, c.mode);
        // the fixed kernel reads only the input kind from the mode word
        const std::vector<DeviceWord> fixed = run(c.fixed, input);
        ASSERT_EQ(fixed.size(), by_mode.size());
        for (std::size_t w = 0; w < fixed.size(); ++w)
          ASSERT_EQ(fixed[w], by_mode[w]) << robot << (tau_input ? " tau" : " qdd") << " input, " << c.name
                                          << ": state " << w / static_cast<std::size_t>(AxiLayout::out_words(n))
                                          << " word " << w % static_cast<std::size_t>(AxiLayout::out_words(n));
        int ok = 0;
        for (int k = 0; k < states; ++k)
          ok += fixed[static_cast<std::size_t>((k + 1) * AxiLayout::out_words(n) - 1)] == kStatusOk;
        EXPECT_GT(ok, 0) << robot << " " << c.name << ": no state in range, nothing compared";
      }
    }
  }
}

TEST(GradientTop, PackingRefusesWhatDoesNotFit) {
  const Model model = testing::load_embedded("iiwa14");
  std::vector<DeviceWord> words;
  std::string error;
  std::vector<double> q(7, 0.1), qd(7, 0.2), u(7, 0.3), minv(49, 0.0);
  EXPECT_TRUE(pack_state(7, q.data(), qd.data(), u.data(), minv.data(), words, error)) << error;
  EXPECT_EQ(words.size(), static_cast<std::size_t>(AxiLayout::in_words(7)));
  qd[3] = 40000.0;  // Q16.16 ends at 32768
  EXPECT_FALSE(pack_state(7, q.data(), qd.data(), u.data(), minv.data(), words, error));
  EXPECT_NE(error.find("qd[3]"), std::string::npos) << error;
  EXPECT_EQ(words.size(), static_cast<std::size_t>(AxiLayout::in_words(7))) << "nothing appended";

  Model heavy = model;
  heavy.mass[2] = 1e6;
  EXPECT_FALSE(pack_robot(heavy, words, error));
  EXPECT_NE(error.find("joint 2"), std::string::npos) << error;
  const Model big = testing::random_model(3, 33, testing::TreeShape::kBranching);
  EXPECT_FALSE(pack_robot(big, words, error));
  EXPECT_NE(error.find("at most 32"), std::string::npos) << error;
}

}  // namespace
}  // namespace rbdgrad::fpga
