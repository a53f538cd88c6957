// Acceptance (issue 7): f64 stays within 1e-8 relative error of the long double reference
// everywhere in its documented valid region.
//
// The documented region: every swept condition (max joint speed 0.01-100 rad/s, link mass and
// inertia ratios 1e-4-1e4 from root to tip, configurations at and near the joint limits and at the
// stretched-out singularity of iiwa14, random chains and trees of up to 64 joints, gravity on and
// off) as long as cond(M) <= 1e7. f64 error grows like 1e-17..1e-16 cond(M); measured on 2026-12-02
// (this grid and bench/stability's full sweep): below 1e-9 up to cond(M) = 1e7, but 1.3e-8 at
// cond(M) = 1.6e8 (64-joint chain, link mass ratio 1e4), so the region stops at 1e7 and the sweeps
// do reach beyond it (SweepCoverage).
#include <gtest/gtest.h>

#include <cstdio>

#include "test_points.hpp"

namespace rbdgrad::stability {
namespace {

constexpr double kMaxCond = 1e7;
constexpr double kMaxError = 1e-8;

TEST(F64ValidRegion, RelativeErrorWithin1e8WhereCondAtMost1e7) {
  int inside = 0, outside = 0;
  double worst_inside = 0, worst_outside = 0;
  for (const Point& p : test_points()) {
    for (size_t k = 0; k < p.samples.size(); ++k) {
      const Sample& s = p.samples[k];
      ASSERT_TRUE(s.reference_ok) << describe(p.spec) << " state " << k;
      const Outcome& o = s.outcome[0];
      if (s.cond > kMaxCond) {
        ++outside;
        if (!o.flagged) worst_outside = std::fmax(worst_outside, o.error());
        continue;
      }
      ++inside;
      // in the region a refused result is a failure too
      EXPECT_FALSE(o.flagged) << describe(p.spec) << " state " << k << ": " << o.message;
      EXPECT_LE(o.err_dq, kMaxError) << describe(p.spec) << " state " << k << " cond " << s.cond;
      EXPECT_LE(o.err_dqd, kMaxError) << describe(p.spec) << " state " << k << " cond " << s.cond;
      worst_inside = std::fmax(worst_inside, o.error());
    }
  }
  std::printf("f64: %d states with cond(M) <= %.0e, worst relative error %.1e; %d beyond, worst %.1e\n", inside,
              kMaxCond, worst_inside, outside, worst_outside);
  // the region is most of what is swept, not a corner of it
  EXPECT_GE(inside, 9 * (inside + outside) / 10);
}

}  // namespace
}  // namespace rbdgrad::stability
