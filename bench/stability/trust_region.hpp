// Where each precision can be trusted, computed from the sweep rows: a grid point is trustworthy
// when the precision's error statistic is within its bound, no state there was flagged or wrong
// by more than 100% without a flag, with gravity on and with gravity off. In the cond(M) bins a
// flagged state does not disqualify (its error is left out): they pool states of every robot, and
// whether a state overflows depends on its magnitudes, not on the conditioning.
#pragma once

#include <string>
#include <vector>

#include "sweep_rows.hpp"

namespace rbdgrad::stability {

struct Criterion {
  int precision = 0;   // index into kPrecisionNames
  bool worst = false;  // the statistic bounded: worst (true) or median (false) relative error
  double bound = 0;

  std::string label() const;  // "f32 median <= 1e-04"
};

// f64: the acceptance bound on the worst error; f32 and Q16.16 at two levels each.
const std::vector<Criterion>& trust_criteria();

bool trustworthy(const Row& r, const Criterion& c);

// The flags of which Row::sweep counts against a grid point.
bool flags_disqualify(const std::string& sweep);

struct Region {
  int points = 0;   // grid points of the sweep
  int passing = 0;  // of them trustworthy
  double lo = 0, hi = 0;  // the longest run of consecutive trustworthy grid points; valid when run > 0
  int run = 0;
};

// Over the rows of one sweep and robot (both gravity settings).
Region trust_region(const std::vector<Row>& rows, const std::string& sweep, const std::string& robot,
                    const Criterion& c);

// "0.01 - 100 (all 17)", "1 - 10 (3 of 17)", "1 - 10 (3 of 17; 5 in all)", "none of 17"
std::string describe(const Region& r);

}  // namespace rbdgrad::stability
