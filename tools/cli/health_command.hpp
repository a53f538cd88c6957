// `rbdgrad health`: the daemon's standard gRPC health check (what a Kubernetes probe asks).
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kHealthSummary = "ask the daemon's gRPC health service: exit 0 when SERVING";

/// Prints the serving status. \return 0 when SERVING, 1 otherwise (another status, or the call
/// failed: the code and message on stderr), 2 on a usage error.
int run_health_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
