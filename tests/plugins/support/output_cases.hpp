// The requests every backend's conformance tests run: sets of outputs, with or without external
// forces and a caller's M^-1; each case runs with tau and with qdd input.
#pragma once

#include <cstdint>

#include "rbdgrad/plugin_api.h"

namespace rbdgrad::testing {

struct OutputCase {
  const char* name;
  std::uint32_t outputs;
  bool fext, minv;
};

inline constexpr std::uint32_t kEveryOutput = 255;
inline constexpr OutputCase kOutputCases[] = {
    {"all outputs", kEveryOutput, false, false},
    {"all outputs, external forces", kEveryOutput, true, false},
    {"all outputs, supplied M^-1, external forces", kEveryOutput, true, true},
    {"d qdd with supplied M^-1", RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD, false, true},
    {"qdd alone, external forces", RBDGRAD_OUTPUT_QDD, true, false},
    {"qdd and M^-1", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV, false, false},
    {"tau alone", RBDGRAD_OUTPUT_TAU, false, false},
    {"tau side and M, external forces",
     RBDGRAD_OUTPUT_TAU | RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_DTAU_DQD | RBDGRAD_OUTPUT_M, true, false},
    {"M alone", RBDGRAD_OUTPUT_M, false, false},
};

}  // namespace rbdgrad::testing
