// SIGINT and SIGTERM for long-running servers (rbdgradd, the benchmarks' echo_server): blocked
// from the start and taken with sigwait, so that no async-signal-safe handler is needed, threads
// started later (gRPC's, the backends') inherit the mask, and a signal during start-up is not lost.
#pragma once

#include <signal.h>

namespace rbdgrad::cli {

/// Blocks SIGINT and SIGTERM in the calling thread (call it before any thread starts) and returns
/// the set for wait_for_stop_signal.
sigset_t block_stop_signals() noexcept;

/// Waits for one of `set`; returns its number, or -1 if sigwait failed.
int wait_for_stop_signal(const sigset_t& set) noexcept;

}  // namespace rbdgrad::cli
