// What the commands that talk to the daemon (info, models, compute) share: the --server and
// --timeout options, the client they make, and how they report a failed call.
#pragma once

#include <iosfwd>
#include <string>
#include <string_view>

#include "args.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::cli {

inline constexpr OptionSpec kServerOption = {
    "server", "ADDR", "the daemon: HOST:PORT or unix:PATH; default 127.0.0.1:50051 (also before the command)"};
inline constexpr OptionSpec kTimeoutOption = {"timeout", "SECONDS", "deadline of each call; default 10"};

/// A client for --server with the --timeout deadline.
/// \return "" or the usage problem ("--timeout: '0' is not a positive number of seconds").
std::string make_client(const Args& args, std::unique_ptr<Client>& out);

/// Prints "rbdgrad <command>: <CODE>: <the server's message> (server <address>)" to stderr.
/// \return 1, the exit code of a failed call.
int report_rpc_failure(std::string_view command, const Client& client, const RpcStatus& status);

}  // namespace rbdgrad::cli
