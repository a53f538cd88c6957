// The states `rbdgrad compute` sends: drawn at random within the model's joint limits, or read
// from a state file (the `rbdgrad eval` format) and checked first like eval does.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rbdgrad/client.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::cli {

// One state to compute: inputs nv values each; u is tau or qdd as `input` says. A state of a file
// that cannot be sent has `error` set instead (eval's message: "state 3: field 'q' has 6 values,
// expected 7") and no inputs.
struct InputState {
  long index = 0;
  std::string kind;
  ComputeInput input = ComputeInput::kTau;
  std::vector<double> q, qd, u;
  std::string error;
};

/// `n` states from a seeded generator (the same seed gives the same states):
/// q uniform within [lower, upper] where the model gives limits, else [-pi, pi] (revolute,
/// continuous) or [-0.5, 0.5] m (prismatic); qd uniform in [-1, 1]; u = tau uniform within half
/// the effort limit (10 N m where none is given), or qdd uniform in [-5, 5]. Index k, kind "random".
std::vector<InputState> random_states(const ModelDescription& model, std::uint32_t n, std::uint64_t seed,
                                      ComputeInput input);

/// The states of `file` for a model of `nv` joints, in file order. Each state's input is tau when
/// it has one, else qdd (as `rbdgrad eval` reads it), unless `forced` names one. A state that
/// fails eval's checks (io::check_dynamics_input; with `forced`, q, qd and that field) gets its
/// error instead of inputs.
std::vector<InputState> file_states(const io::StateFile& file, int nv, const ComputeInput* forced);

}  // namespace rbdgrad::cli
