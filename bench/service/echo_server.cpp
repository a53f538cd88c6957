// echo_server: the transport floor of the service benchmark. Serves the Echo service of echo.proto
// on TCP and/or a Unix socket until SIGINT/SIGTERM, and announces its bound addresses through a
// ready file the same way rbdgradd does (lines "tcp 127.0.0.1:41234" / "unix /path").

#include <climits>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "args.hpp"
#include "echo_service.hpp"
#include "ready_file.hpp"
#include "stop_signals.hpp"

namespace {

constexpr rbdgrad::cli::OptionSpec kOptions[] = {
    {"listen", "HOST:PORT", "TCP address; port 0 picks a free one (see --ready-file); default: no TCP"},
    {"unix-socket", "PATH", "Unix-domain socket to listen on; default: none"},
    {"ready-file", "PATH", "once serving, write the bound addresses here (atomically, by rename)"},
    {"api", "callback|sync", "gRPC server API; default callback (the leaner floor here, see bench/README.md)"},
    {"help", "", "show this help"},
};

void print_help(std::ostream& os) {
  os << "usage: echo_server [--listen HOST:PORT] [--unix-socket PATH] [--ready-file PATH] [--api callback|sync]\n\n"
     << "Echo service of bench/service/echo.proto, the transport floor of service_load.\n\noptions:\n"
     << rbdgrad::cli::format_options(kOptions);
}

}  // namespace

int main(int argc, char** argv) {
  // blocked before gRPC starts its threads, so that only the wait below takes them
  const sigset_t stop = rbdgrad::cli::block_stop_signals();

  rbdgrad::cli::Args args;
  if (std::string error = rbdgrad::cli::Args::parse(kOptions, argc, argv, 1, args); !error.empty()) {
    std::cerr << "echo_server: " << error << "\n";
    print_help(std::cerr);
    return 2;
  }
  if (args.has("help")) {
    print_help(std::cout);
    return 0;
  }
  const std::string tcp = args.value_or("listen", "");
  const std::string unix_path = args.value_or("unix-socket", "");
  const std::string api = args.value_or("api", "callback");
  if (tcp.empty() && unix_path.empty()) {
    std::cerr << "echo_server: give --listen and/or --unix-socket\n";
    return 2;
  }
  if (api != "callback" && api != "sync") {
    std::cerr << "echo_server: --api must be callback or sync, not '" << api << "'\n";
    return 2;
  }

  rbdgrad::bench::CallbackEchoService callback_service;
  rbdgrad::bench::SyncEchoService sync_service;
  grpc::ServerBuilder builder;
  // the largest benchmark payloads (talos_reduced, N = 1024) exceed gRPC's 4 MiB default
  builder.SetMaxReceiveMessageSize(INT_MAX);
  builder.SetMaxSendMessageSize(INT_MAX);
  int tcp_port = 0;
  if (!tcp.empty()) builder.AddListeningPort(tcp, grpc::InsecureServerCredentials(), &tcp_port);
  if (!unix_path.empty()) builder.AddListeningPort("unix:" + unix_path, grpc::InsecureServerCredentials());
  if (api == "callback")
    builder.RegisterService(&callback_service);
  else
    builder.RegisterService(&sync_service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || (!tcp.empty() && tcp_port == 0)) {
    std::cerr << "echo_server: cannot listen on" << (tcp.empty() ? "" : " tcp " + tcp)
              << (unix_path.empty() ? "" : " unix " + unix_path) << "\n";
    return 1;
  }

  // "127.0.0.1:0" -> "127.0.0.1:41234"
  std::vector<rbdgrad::server::ListenAddress> addresses;
  if (!tcp.empty()) addresses.push_back({"tcp", tcp.substr(0, tcp.rfind(':')) + ":" + std::to_string(tcp_port)});
  if (!unix_path.empty()) addresses.push_back({"unix", unix_path});
  std::cout << "echo_server (" << api << " API) serving:\n";
  for (const auto& a : addresses) std::cout << a.text() << "\n";
  std::cout << std::flush;
  const std::string ready = args.value_or("ready-file", "");
  if (!ready.empty()) {
    if (const rbdgrad::Status s = rbdgrad::server::write_ready_file(ready, addresses); !s) {
      std::cerr << "echo_server: " << s.to_string() << "\n";
      server->Shutdown();
      return 1;
    }
  }

  const int signal = rbdgrad::cli::wait_for_stop_signal(stop);
  // open streams are cancelled after the grace period; a benchmark client has closed them by then
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  server->Wait();
  if (!ready.empty()) std::remove(ready.c_str());
  std::cout << "echo_server: stopped (signal " << signal << ")\n";
  return 0;
}
