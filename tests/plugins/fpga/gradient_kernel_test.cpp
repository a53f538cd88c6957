// The FPGA kernel's C simulation (plugins/fpga/kernel/gradient_kernel.hpp) against the Pinocchio
// reference (tests/data/reference): in double, the algorithm itself (1e-10); in fixed point, the
// error of each format, bounded per robot, with every state that leaves a format's range flagged
// by the overflow status rather than returned wrong.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "../../support/error_statistics.hpp"
#include "../../support/test_models.hpp"
#include "kernel/gradient_kernel.hpp"
#include "kernel/robot_constants.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::fpga {
namespace {

constexpr int kMaxNv = 32;

struct Errors {
  std::vector<double> dq, dqd;  // relative Frobenius error per computed state
  int overflowed = 0;           // states flagged out of range
};

double relative_error(const std::vector<double>& got, const std::vector<double>& ref) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < ref.size(); ++k) {
    num += (got[k] - ref[k]) * (got[k] - ref[k]);
    den += ref[k] * ref[k];
  }
  return std::sqrt(num / std::max(den, 1e-300));
}

template <class T>
Errors run(const std::string& robot, bool tau_input) {
  io::StateFile file;
  std::string error;
  EXPECT_TRUE(io::read_state_file(std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl", file, error))
      << error;
  const Model model = testing::load_embedded(robot);
  auto constants = std::make_unique<RobotConstants<T, kMaxNv>>();
  EXPECT_TRUE(robot_constants(model, *constants));
  auto state = std::make_unique<KernelState<T, kMaxNv>>();
  const auto n = static_cast<std::size_t>(model.nv);
  Errors errors;
  for (const io::StateRecord& r : file.states) {
    // from the conversion of the inputs on: an input outside the format's range is out of range too
    const FixedOverflowScope scope;
    auto in = [&](const char* field) {
      std::vector<T> out;
      for (double x : r.at(field)) out.push_back(T(x));
      return out;
    };
    const std::vector<T> q = in("q"), qd = in("qd"), u = in(tau_input ? "tau" : "qdd"), minv = in("Minv");
    std::vector<T> sin_q, cos_q;
    for (double x : r.at("q")) {
      sin_q.push_back(T(std::sin(x)));
      cos_q.push_back(T(std::cos(x)));
    }
    std::vector<T> qdd(n), dq(n * n), dqd(n * n);
    fd_gradient(*constants, q.data(), sin_q.data(), cos_q.data(), qd.data(), u.data(), tau_input, minv.data(), *state,
                qdd.data(), dq.data(), dqd.data());
    if (scope.overflowed()) {
      ++errors.overflowed;
      continue;
    }
    auto as_double = [](const std::vector<T>& x) {
      std::vector<double> out;
      for (const T& e : x) out.push_back(static_cast<double>(e));
      return out;
    };
    errors.dq.push_back(relative_error(as_double(dq), r.at("dqdd_dq")));
    errors.dqd.push_back(relative_error(as_double(dqd), r.at("dqdd_dqd")));
  }
  std::printf("%s %s %s input: d qdd/d q %.1e / %.1e, d qdd/d qd %.1e / %.1e (median / worst), %d of %zu states "
              "out of range\n",
              robot.c_str(), scalar_name<T>(), tau_input ? "tau" : "qdd", testing::median_of(errors.dq),
              testing::worst_of(errors.dq), testing::median_of(errors.dqd), testing::worst_of(errors.dqd),
              errors.overflowed, file.states.size());
  return errors;
}

class GradientKernel : public ::testing::TestWithParam<const char*> {};

TEST_P(GradientKernel, DoubleMatchesTheReference) {
  for (const bool tau_input : {false, true}) {
    const Errors e = run<double>(GetParam(), tau_input);
    EXPECT_EQ(e.overflowed, 0);
    EXPECT_LE(testing::worst_of(e.dq), 1e-10);
    EXPECT_LE(testing::worst_of(e.dqd), 1e-10);
  }
}

// Per robot and format, over the 32 reference states and both input kinds: the worst relative
// error of d qdd/d q and d qdd/d qd among the states in range, and how many states left the range
// (flagged, not returned). Measured on 2026-12-02 and rounded up by about 25%; fixed-point
// arithmetic is integer-exact, so the figures move only when the kernel changes. Six of the iiwa14
// reference states have an acceleration of the light last joint beyond Q16.16's 32768 rad/s^2
// (up to 4.0e4): they, and one more, are out of that range.
struct FormatBound {
  const char* robot;
  double dq, dqd;
  int out_of_range;
};
constexpr FormatBound kQ16_16[] = {{"iiwa14", 8.4e-3, 1.8e-2, 7},
                                   {"panda", 1.5e-3, 3.3e-3, 0},
                                   {"talos_reduced", 3.3e-3, 7.5e-3, 0},
                                   {"hyq", 1.2e-4, 4.8e-4, 0}};
// wider: 24 integer and 24 fractional bits
constexpr FormatBound kQ24_24[] = {{"iiwa14", 1.5e-5, 5e-5, 0},
                                   {"panda", 7.5e-6, 1.9e-5, 0},
                                   {"talos_reduced", 6.4e-6, 2.8e-5, 0},
                                   {"hyq", 6.8e-7, 2.1e-6, 0}};
// narrower: Q16.16's range with 12 fractional bits
constexpr FormatBound kQ16_12[] = {{"iiwa14", 2.8e-2, 0.19, 7},
                                   {"panda", 2.7e-2, 7.8e-2, 0},
                                   {"talos_reduced", 6.7e-2, 0.1, 0},
                                   {"hyq", 2.8e-3, 7e-3, 0}};

template <class T, std::size_t N>
void check_format(const std::string& robot, const FormatBound (&bounds)[N]) {
  const FormatBound* bound = nullptr;
  for (const FormatBound& b : bounds)
    if (robot == b.robot) bound = &b;
  ASSERT_NE(bound, nullptr);
  for (const bool tau_input : {false, true}) {
    const Errors e = run<T>(robot, tau_input);
    const std::string where = robot + " " + scalar_name<T>() + (tau_input ? " tau input" : " qdd input");
    EXPECT_LE(e.overflowed, bound->out_of_range) << where;
    EXPECT_GE(e.dq.size(), 24u) << where << ": most states stay in range";
    EXPECT_LE(testing::worst_of(e.dq), bound->dq) << where;
    EXPECT_LE(testing::worst_of(e.dqd), bound->dqd) << where;
  }
}

TEST_P(GradientKernel, Q16_16WithinItsMeasuredBound) { check_format<Q16_16>(GetParam(), kQ16_16); }
TEST_P(GradientKernel, Q24_24WithinItsMeasuredBound) { check_format<Fixed<48, 24>>(GetParam(), kQ24_24); }
TEST_P(GradientKernel, Q16_12WithinItsMeasuredBound) { check_format<Fixed<28, 12>>(GetParam(), kQ16_12); }

// A state far out of the format's range is flagged, never returned as if it were right.
TEST(GradientKernelOverflow, FastStatesAreFlagged) {
  const Model model = testing::load_embedded("iiwa14");
  auto constants = std::make_unique<RobotConstants<Q16_16, kMaxNv>>();
  ASSERT_TRUE(robot_constants(model, *constants));
  auto state = std::make_unique<KernelState<Q16_16, kMaxNv>>();
  const int n = model.nv;
  std::vector<Q16_16> q(7, Q16_16(0.3)), s(7), c(7), qd(7, Q16_16(300.0)), qdd(7, Q16_16(1.0)), minv(49, Q16_16(0));
  for (int i = 0; i < n; ++i) {
    s[i] = Q16_16(std::sin(0.3));
    c[i] = Q16_16(std::cos(0.3));
    minv[i * n + i] = Q16_16(1.0);
  }
  std::vector<Q16_16> out_qdd(7), dq(49), dqd(49);
  const FixedOverflowScope fast;
  fd_gradient(*constants, q.data(), s.data(), c.data(), qd.data(), qdd.data(), false, minv.data(), *state,
              out_qdd.data(), dq.data(), dqd.data());
  EXPECT_TRUE(fast.overflowed()) << "300 rad/s on every joint must leave Q16.16's range";
  std::fill(qd.begin(), qd.end(), Q16_16(0.1));
  const FixedOverflowScope slow;
  fd_gradient(*constants, q.data(), s.data(), c.data(), qd.data(), qdd.data(), false, minv.data(), *state,
              out_qdd.data(), dq.data(), dqd.data());
  EXPECT_FALSE(slow.overflowed()) << "a slow state stays in range";
}

INSTANTIATE_TEST_SUITE_P(Robots, GradientKernel, ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq"),
                         [](const auto& param_info) { return std::string(param_info.param); });

}  // namespace
}  // namespace rbdgrad::fpga
