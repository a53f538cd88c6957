// What the commands that talk to the daemon (info, calibrate, models, scenes, compute, health)
// share: the --server, TLS, token and --timeout options, the client they make, and how they
// report a failed call.
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
// TLS and the bearer token (the daemon's tls and auth sections); also before the command
inline constexpr OptionSpec kTlsCaOption = {
    "tls-ca", "FILE", "TLS: the PEM CA certificate the server's certificate must chain to (also before the command)"};
inline constexpr OptionSpec kTlsCertOption = {
    "tls-cert", "FILE", "mutual TLS: this client's PEM certificate chain, with --tls-key (also before the command)"};
inline constexpr OptionSpec kTlsKeyOption = {"tls-key", "FILE",
                                             "mutual TLS: this client's PEM private key (also before the command)"};
inline constexpr OptionSpec kTokenFileOption = {
    "token-file", "FILE", "send the token in FILE (its one line) as 'authorization: Bearer' (also before the command)"};

/// A client for --server with the --timeout deadline, TLS when --tls-ca, --tls-cert or --tls-key
/// is given, and the token of --token-file.
/// \return "" or the usage problem ("--timeout: '0' is not a positive number of seconds",
///         "--token-file: cannot read 'x'").
std::string make_client(const Args& args, std::unique_ptr<Client>& out);

/// Prints "rbdgrad <command>: <CODE>: <the server's message> (server <address>)" to stderr.
/// \return 1, the exit code of a failed call.
int report_rpc_failure(std::string_view command, const Client& client, const RpcStatus& status);

}  // namespace rbdgrad::cli
