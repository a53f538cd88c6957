// The per-state result the fused kernel writes (one uint32 per state), and its encoding: why the
// state failed, in which algorithm, at which joint. The host turns it into the core's message
// (status_message.hpp), so that a state fails with the same words on every backend.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

enum class Reason : std::uint32_t {
  kOk = 0,
  kNotFinite = 1,        // NaN or Inf in an output of `algorithm`
  kMassNotFinite = 2,    // M not finite at `joint` (factorization)
  kMassNotPositive = 3,  // M not positive definite at `joint` (factorization)
};

// The core algorithm whose outputs are checked (the name in "<algorithm>: result is not finite").
enum class Algorithm : std::uint32_t {
  kNone = 0,
  kFdDerivatives = 1,
  kMinverse = 2,
  kForwardDynamics = 3,
  kRneaDerivatives = 4,
  kRnea = 5,
  kCrba = 6,
};

// bits 0-7 reason, 8-15 algorithm, 16-31 joint
RBDGRAD_HD std::uint32_t state_status(Reason reason, Algorithm algorithm, int joint) {
  return static_cast<std::uint32_t>(reason) | static_cast<std::uint32_t>(algorithm) << 8 |
         static_cast<std::uint32_t>(joint) << 16;
}
RBDGRAD_HD Reason status_reason(std::uint32_t s) { return static_cast<Reason>(s & 0xff); }
RBDGRAD_HD Algorithm status_algorithm(std::uint32_t s) { return static_cast<Algorithm>((s >> 8) & 0xff); }
RBDGRAD_HD int status_joint(std::uint32_t s) { return static_cast<int>(s >> 16); }

}  // namespace rbdgrad::cuda
