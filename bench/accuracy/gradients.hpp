// One batch's gradients as double, whichever precision computed them, with each state's status.
// The in-process kernel also gives q̈ and the M⁻¹ it used (a linearization needs both: B = dt M⁻¹).
#pragma once

#include <cstdint>
#include <vector>

namespace rbdgrad::bench {

struct Gradients {
  std::vector<double> dqdd_dq, dqdd_dqd;  // n * nv * nv, each matrix row-major
  std::vector<std::int32_t> state_status;  // n: 0 = computed, else the backend's error code (flagged)
  // empty unless the producer fills them (run_fixed_format does), as rounded into its precision
  std::vector<double> qdd;   // n * nv
  std::vector<double> minv;  // n * nv * nv, row-major
};

}  // namespace rbdgrad::bench
