// `rbdgrad scenes`: the scenes the daemon serves.
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kScenesSummary = "list the scenes the daemon serves (models reduced for one problem)";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_scenes_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
