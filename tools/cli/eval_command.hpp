// `rbdgrad eval`: evaluates dynamics outputs for every state of a JSON Lines file.
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kEvalSummary = "evaluate dynamics and derivatives for a file of states";

/// Runs `rbdgrad eval` with argv[first..argc) as its options.
/// \return the exit code: 0 every state evaluated; 1 a state failed (each has an error object in the
///         output) or a file could not be read or written; 2 a usage error.
int run_eval_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
