// Acceptance (issue 7): no precision hands on a NaN, an Inf or a saturated fixed-point value
// without flagging it (a non-ok Status or a fixed-point overflow), in any swept state and for
// inputs far beyond the sweeps.
#include <gtest/gtest.h>

#include <limits>

#include "test_points.hpp"

namespace rbdgrad::stability {
namespace {

TEST(NoSilentFailure, EverySweptStateInEveryPrecision) {
  for (const Point& p : test_points())
    for (size_t k = 0; k < p.samples.size(); ++k)
      for (int prec = 0; prec < kNumPrecisions; ++prec)
        EXPECT_FALSE(p.samples[k].outcome[prec].silent_failure())
            << kPrecisionNames[prec] << " " << describe(p.spec) << " state " << k;
}

// Speeds far beyond the sweep and a NaN input, with arbitrary torques: each precision must fail
// loudly once its range is exceeded. The speeds where it must fail are where v^2 leaves the range:
// Q16.16 (|x| < 32768) at 1e3 rad/s, f32 (3.4e38) at 1e20, f64 (1.8e308) at 1e200.
TEST(NoSilentFailure, InputsBeyondEachRangeAreFlagged) {
  struct Extreme {
    double speed;
    bool flagged[kNumPrecisions];  // f64, f32, fixed
  };
  const Extreme cases[] = {{1e3, {false, false, true}}, {1e20, {false, true, true}}, {1e200, {true, true, true}}};
  for (const char* robot : {"iiwa14", "chain64"}) {
    const Model m = robot_model(robot);
    PrecisionRun<double> f64(m);
    PrecisionRun<float> f32(m);
    PrecisionRun<Q16_16> fixed(m);
    std::mt19937 rng(7);
    const Reference none;  // flags only: no error is measured
    for (const Extreme& e : cases) {
      StateInput s{random_configuration(m, rng), velocity_with_max(rng, m.nv, e.speed), testing::random_vector(rng, m.nv, 10)};
      const Outcome o[kNumPrecisions] = {f64.run(s, none), f32.run(s, none), fixed.run(s, none)};
      for (int prec = 0; prec < kNumPrecisions; ++prec) {
        EXPECT_FALSE(o[prec].silent_failure()) << robot << " " << kPrecisionNames[prec] << " at " << e.speed;
        if (e.flagged[prec]) {
          EXPECT_TRUE(o[prec].flagged) << robot << " " << kPrecisionNames[prec] << " at " << e.speed;
        }
      }
      // NaN in one joint's speed: floating point propagates it, fixed point has no NaN to convert to
      s.qd(m.nv / 2) = std::numeric_limits<double>::quiet_NaN();
      const Outcome n[kNumPrecisions] = {f64.run(s, none), f32.run(s, none), fixed.run(s, none)};
      for (int prec = 0; prec < kNumPrecisions; ++prec)
        EXPECT_TRUE(n[prec].flagged) << robot << " " << kPrecisionNames[prec] << " NaN input";
    }
  }
}

}  // namespace
}  // namespace rbdgrad::stability
