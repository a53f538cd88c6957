// `rbdgrad compute`: dynamics and gradients computed by the daemon (random states or a state file).
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kComputeSummary = "compute dynamics and derivatives on the daemon (random states or a file)";

/// Runs `rbdgrad compute` with argv[first..argc) as its options.
/// \return 0 every state computed and finite; 1 a call failed (the server's code and message on
///         stderr), a state failed (an error object in the results) or a file error; 2 a usage error.
int run_compute_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
