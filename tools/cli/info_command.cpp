// `rbdgrad info`: prints GetServerInfo.
#include "info_command.hpp"

#include <iostream>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption, kTimeoutOption, {"help", "", "show this help"}};

std::string bytes_text(std::uint64_t bytes) {
  if (bytes >= (1u << 20) && bytes % (1u << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

}  // namespace

int run_info_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad info [--server ADDR]\n\n" << kInfoSummary << ".\n\noptions:\n" << format_options(kOptions);
    return 0;
  }
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad info: " << error << "\nusage: rbdgrad info [--server ADDR] (see rbdgrad info --help)\n";
    return 2;
  }
  ServerInfo info;
  if (RpcStatus st = client->server_info(info); !st) return report_rpc_failure("info", *client, st);

  std::cout << "server " << client->address() << ": rbdgrad " << info.version << "\nbackends:\n";
  for (const BackendStatus& b : info.backends) {
    std::cout << "  " << b.name << ": ";
    if (!b.ready) {
      std::cout << "unavailable (" << b.reason << ")\n";
      continue;
    }
    std::cout << "ready";
    // a stand-in says so before anything else: csim computes like the FPGA, not as fast
    if (!b.mode.empty()) std::cout << " (" << b.mode << ")";
    if (!b.device.empty()) std::cout << " on " << b.device;
    std::cout << ", precisions ";
    for (std::size_t i = 0; i < b.precisions.size(); ++i) std::cout << (i ? ", " : "") << precision_name(b.precisions[i]);
    std::cout << ", max batch " << (b.max_batch ? std::to_string(b.max_batch) : "unlimited") << "\n";
  }
  std::cout << "limits: " << info.max_states_per_request << " states per request, messages up to "
            << bytes_text(info.max_message_bytes) << ", " << info.max_concurrent_requests << " requests in flight\n";
  return 0;
}

}  // namespace rbdgrad::cli
