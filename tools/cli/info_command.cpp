// `rbdgrad info`: prints GetServerInfo.
#include "info_command.hpp"

#include <cstdio>
#include <iostream>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption,    kTlsCaOption,   kTlsCertOption,           kTlsKeyOption,
                                   kTokenFileOption, kTimeoutOption, {"help", "", "show this help"}};

std::string bytes_text(std::uint64_t bytes) {
  if (bytes >= (1u << 20) && bytes % (1u << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

}  // namespace

void print_server_info(const std::string& address, const ServerInfo& info) {
  std::cout << "server " << address << ": rbdgrad " << info.version << "\nbackends:\n";
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
    if (!b.detail.empty()) std::cout << " [" << b.detail << "]";
    std::cout << ", precisions ";
    for (std::size_t i = 0; i < b.precisions.size(); ++i) std::cout << (i ? ", " : "") << precision_name(b.precisions[i]);
    std::cout << ", max batch " << (b.max_batch ? std::to_string(b.max_batch) : "unlimited") << "\n";
    for (const LatencyModelStatus& m : b.latency_models) {
      char line[200];
      std::snprintf(line, sizeof line, "    latency %s %s: %.4g us for 1 state", m.model.c_str(),
                    precision_name(m.precision), m.fixed_us);
      std::cout << line;
      if (m.n.size() >= 2) {
        std::snprintf(line, sizeof line, ", %.4g us for %llu, then %.3g us/state", m.us.back(),
                      static_cast<unsigned long long>(m.n.back()), m.per_state_us);
        std::cout << line;
      }
      std::cout << " (" << m.source << ")\n";
    }
    for (const QueueStatus& q : b.queues) {
      if (q.queued == 0 && q.running == 0) continue;
      std::cout << "    queue " << q.model << ": " << q.queued << " waiting, " << q.running << " running, "
                << static_cast<long long>(q.pending_us) << " us predicted\n";
    }
  }
  std::cout << "routing (" << (info.scheduler_policy.empty() ? "?" : info.scheduler_policy) << " policy):\n";
  for (const RoutingStatus& r : info.routing) {
    std::cout << "  " << r.model << ": ";
    if (r.crossovers.empty()) std::cout << "no latency models: the cpu takes requests without a backend";
    for (std::size_t i = 0; i < r.crossovers.size(); ++i)
      std::cout << (i ? ", " : "") << r.crossovers[i].second << " from N = " << r.crossovers[i].first;
    if (info.scheduler_policy == "threshold")
      std::cout << " (small_n " << r.small_n << ", large_n " << r.large_n << ")";
    std::cout << "\n";
  }
  std::cout << "limits: " << info.max_states_per_request << " states per request, messages up to "
            << bytes_text(info.max_message_bytes) << ", " << info.max_concurrent_requests << " requests in flight\n";
}

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

  print_server_info(client->address(), info);
  return 0;
}

}  // namespace rbdgrad::cli
