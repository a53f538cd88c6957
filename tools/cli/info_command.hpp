// `rbdgrad info`: what the daemon says about itself (version, backends, limits).
#pragma once

#include <string>

#include "rbdgrad/service_info.hpp"

namespace rbdgrad::cli {

inline constexpr const char* kInfoSummary = "show the daemon's version, backends and limits";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_info_command(int argc, const char* const* argv, int first);

/// GetServerInfo's answer as `rbdgrad info` prints it (also after `rbdgrad calibrate`).
void print_server_info(const std::string& address, const ServerInfo& info);

}  // namespace rbdgrad::cli
