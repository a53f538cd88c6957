// `rbdgrad info`: what the daemon says about itself (version, backends, limits).
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kInfoSummary = "show the daemon's version, backends and limits";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_info_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
