// One batch's gradients as double, whichever precision computed them, with each state's status.
#pragma once

#include <cstdint>
#include <vector>

namespace rbdgrad::bench {

struct Gradients {
  std::vector<double> dqdd_dq, dqdd_dqd;  // n * nv * nv, each matrix row-major
  std::vector<std::int32_t> state_status;  // n: 0 = computed, else the backend's error code (flagged)
};

}  // namespace rbdgrad::bench
