// The states the accuracy benchmark computes: seeded random states within a model's limits (for
// timing, and for the error against the float64 result), and the Pinocchio reference states of
// tests/data/reference/<robot>.jsonl with their expected gradients (the error against Pinocchio).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::bench {

/// n states of a model with nv joints, state-major: state k's q is q[k * nv, (k + 1) * nv).
struct StateSet {
  int nv = 0;
  std::size_t n = 0;
  std::vector<double> q, qd, tau;
  // the expected dqdd/dq and dqdd/dqd (n * nv * nv, each matrix row-major); empty for random states
  std::vector<double> dqdd_dq, dqdd_dqd;
};

/// n states drawn with a seeded generator, as `rbdgrad compute` draws them: q uniform within the
/// joint limits (else [-pi, pi], or [-0.5, 0.5] m for a prismatic joint), qd uniform in [-1, 1],
/// tau uniform within half the effort limit (10 N m where the model gives none).
StateSet random_states(const Model& model, std::size_t n, std::uint64_t seed);

/// The states of a Pinocchio reference file (q, qd, tau, dqdd_dq, dqdd_dqd of each state line).
/// Errors: the file's own (not found, malformed), or a state of another size than the model's.
Status reference_states(const std::string& path, const Model& model, StateSet& out);

/// The first n states of `set` (n <= set.n), repeated cyclically when n > set.n.
StateSet first_states(const StateSet& set, std::size_t n);

}  // namespace rbdgrad::bench
