// `rbdgrad model`: prints the summary of a robot model (joints, parents, mass, gravity).
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kModelSummary = "print the summary of a robot model";

/// \return 0, 1 when the model cannot be loaded, 2 on a usage error.
int run_model_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
