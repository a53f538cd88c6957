// `rbdgrad health`: grpc.health.v1.Health/Check through Client::check_health.
#include "health_command.hpp"

#include <iostream>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {
    kServerOption,
    kTlsCaOption,
    kTlsCertOption,
    kTlsKeyOption,
    kTokenFileOption,
    {"service", "NAME", "the service whose status to ask (e.g. rbdgrad.v1.Dynamics); default \"\", the whole server"},
    kTimeoutOption,
    {"help", "", "show this help"},
};

}  // namespace

int run_health_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad health [--server ADDR] [--service NAME]\n\n"
              << kHealthSummary << ".\nThe health service needs no token; a stopping daemon answers NOT_SERVING.\n\n"
              << "options:\n" << format_options(kOptions)
              << "\nexit status: 0 SERVING, 1 any other status or a failed call, 2 usage error\n";
    return 0;
  }
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad health: " << error << "\nusage: rbdgrad health [--server ADDR] (see rbdgrad health --help)\n";
    return 2;
  }
  std::string status;
  if (RpcStatus st = client->check_health(status, args.value_or("service", "")); !st)
    return report_rpc_failure("health", *client, st);
  std::cout << status << "\n";
  return status == "SERVING" ? 0 : 1;
}

}  // namespace rbdgrad::cli
