// The error of a batch's gradients against expected ones: per state the relative Frobenius error
// of each matrix (as the reference accuracy tests measure it), then the median and the worst over
// the states the backend did not flag. Flagged states are counted; a non-finite value in a state
// that was not flagged is counted apart: that is an error passed on silently.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "gradients.hpp"

namespace rbdgrad::bench {

struct ErrorSummary {
  double median = std::numeric_limits<double>::quiet_NaN();  // NaN when no state was compared
  double worst = std::numeric_limits<double>::quiet_NaN();
};

struct GradientErrors {
  ErrorSummary dqdd_dq, dqdd_dqd;
  std::size_t states = 0;               // compared
  std::size_t flagged = 0;              // the backend's state_status said so
  std::size_t unflagged_nonfinite = 0;  // NaN or Inf in a state not flagged
};

/// `got` against `want_dq` and `want_dqd` (n * nv * nv each, row-major per state).
GradientErrors compare_gradients(const Gradients& got, const std::vector<double>& want_dq,
                                 const std::vector<double>& want_dqd, int nv);

}  // namespace rbdgrad::bench
