// `rbdgrad calibrate`: the daemon times its backends again (the scheduler's latency models).
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kCalibrateSummary = "have the daemon time its backends again (routing)";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_calibrate_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
