// `rbdgrad models`: the models the daemon serves.
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kModelsSummary = "list the models the daemon serves";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_models_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
