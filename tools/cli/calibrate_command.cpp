// `rbdgrad calibrate`: Calibrate, then the measured models and the routing they imply.
#include "calibrate_command.hpp"

#include <chrono>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "info_command.hpp"
#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption,
                                   kTlsCaOption,
                                   kTlsCertOption,
                                   kTlsKeyOption,
                                   kTokenFileOption,
                                   {"timeout", "SECONDS", "deadline of the call; default 300 (a calibration takes seconds)"},
                                   {"help", "", "show this help"}};

}  // namespace

int run_calibrate_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad calibrate [--server ADDR] [--timeout SECONDS]\n\n" << kCalibrateSummary
              << ": every backend on every model and precision, over the batch sizes of the daemon's\n"
                 "scheduler.calibration_sizes (the FPGA plugin's cycle model is kept). Requests computed\n"
                 "meanwhile skew the timings: run it when the daemon is idle.\n\noptions:\n"
              << format_options(kOptions);
    return 0;
  }
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad calibrate: " << error
              << "\nusage: rbdgrad calibrate [--server ADDR] [--timeout SECONDS] (see rbdgrad calibrate --help)\n";
    return 2;
  }
  std::vector<std::string> log;
  ServerInfo info;
  // the client's default deadline (10 s) is for quick calls: this one gets 300 s unless --timeout
  std::optional<std::chrono::nanoseconds> timeout;
  if (!args.has("timeout")) timeout = std::chrono::seconds(300);
  if (RpcStatus st = client->calibrate(log, info, timeout); !st) return report_rpc_failure("calibrate", *client, st);
  for (const std::string& line : log) std::cout << line << "\n";
  print_server_info(client->address(), info);
  return 0;
}

}  // namespace rbdgrad::cli
