// The sweeps reach the hard cases they claim to (issue 7): cond(M) over many decades and beyond
// f64's valid region, link ratios at both ends, 64-joint chains and trees, and the ranges of f32
// and Q16.16 exceeded (so that flagging is exercised, not only assumed).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "test_points.hpp"

namespace rbdgrad::stability {
namespace {

double median_cond(const Point& p) {
  std::vector<double> cond;
  for (const Sample& s : p.samples)
    if (s.reference_ok) cond.push_back(s.cond);
  if (cond.empty()) return 0;
  std::sort(cond.begin(), cond.end());
  return cond[cond.size() / 2];
}

TEST(SweepCoverage, ConditionNumbersSpanSixDecadesAndPassF64sRegion) {
  double lo = 1e300, hi = 0;
  for (const Point& p : test_points())
    for (const Sample& s : p.samples)
      if (s.reference_ok) {
        lo = std::min(lo, s.cond);
        hi = std::max(hi, s.cond);
      }
  std::printf("cond(M) from %.1e to %.1e\n", lo, hi);
  EXPECT_GE(hi / lo, 1e6);
  EXPECT_GT(hi, 1e7);  // beyond the f64 region (f64_valid_region_test.cpp)
}

TEST(SweepCoverage, ReachesTheEndsOfEveryRange) {
  double speed[2] = {1e300, 0}, ratio[2] = {1e300, 0};
  int joints = 0;
  bool chain = false, tree = false;
  for (const Point& p : test_points()) {
    const PointSpec& s = p.spec;
    EXPECT_GE(p.samples.size(), 1u) << describe(s);
    if (s.sweep == "velocity") speed[0] = std::min(speed[0], s.x), speed[1] = std::max(speed[1], s.x);
    if (s.sweep == "mass_ratio") ratio[0] = std::min(ratio[0], s.x), ratio[1] = std::max(ratio[1], s.x);
    if (s.sweep == "joints") joints = std::max(joints, static_cast<int>(s.x));
    chain = chain || s.robot == "chain64";
    tree = tree || s.robot == "tree64";
  }
  EXPECT_LE(speed[0], 0.01);
  EXPECT_GE(speed[1], 100);
  EXPECT_LE(ratio[0], 1e-4);
  EXPECT_GE(ratio[1], 1e4);
  EXPECT_EQ(joints, 64);
  EXPECT_TRUE(chain && tree);
}

// Q16.16 must overflow on iiwa14 at 100 rad/s (|v x I v| > 32768), and f32 must refuse a mass
// matrix it cannot factor (cond(M) above 1/eps = 1.7e7) somewhere in the sweeps.
TEST(SweepCoverage, LowerPrecisionsAreDrivenOutOfRange) {
  int fixed_at_100 = 0, f32_flagged = 0;
  for (const Point& p : test_points())
    for (const Sample& s : p.samples) {
      if (p.spec.sweep == "velocity" && p.spec.robot == "iiwa14" && p.spec.x >= 100) fixed_at_100 += s.outcome[2].flagged;
      f32_flagged += s.outcome[1].flagged;
    }
  EXPECT_GT(fixed_at_100, 0);
  EXPECT_GT(f32_flagged, 0);
}

// One line per point: median cond(M), then per precision median/worst error, flagged states and
// unflagged states with an error above 1.
TEST(SweepCoverage, PrintsTheErrorOfEveryPoint) {
  for (const Point& p : test_points()) {
    std::printf("%-13s %-12s g%d x=%-8.2g cond %8.1e", p.spec.sweep.c_str(), p.spec.robot.c_str(), p.spec.gravity,
                p.spec.x, median_cond(p));
    for (int prec = 0; prec < kNumPrecisions; ++prec) {
      const ErrorSummary e = summarize(p, prec);
      std::printf(" | %s %.1e/%.1e f%d w%d", kPrecisionNames[prec], e.median(), e.worst(), e.flagged, e.wrong);
    }
    std::printf("\n");
  }
}

}  // namespace
}  // namespace rbdgrad::stability
