// `rbdgrad models`: prints ListModels as a table (name, nv, source).
#include "models_command.hpp"

#include <algorithm>
#include <iostream>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption,    kTlsCaOption,   kTlsCertOption,           kTlsKeyOption,
                                   kTokenFileOption, kTimeoutOption, {"help", "", "show this help"}};

}  // namespace

int run_models_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad models [--server ADDR]\n\n" << kModelsSummary << ".\n\noptions:\n" << format_options(kOptions);
    return 0;
  }
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad models: " << error << "\nusage: rbdgrad models [--server ADDR] (see rbdgrad models --help)\n";
    return 2;
  }
  std::vector<ServedModel> models;
  if (RpcStatus st = client->list_models(models); !st) return report_rpc_failure("models", *client, st);

  std::size_t width = 4;  // "NAME"
  for (const ServedModel& m : models) width = std::max(width, m.name.size());
  auto pad = [](const std::string& s, std::size_t w) { return s + std::string(w - std::min(w, s.size()), ' '); };
  std::cout << pad("NAME", width) << "  NV  SOURCE\n";
  for (const ServedModel& m : models) {
    const std::string nv = std::to_string(m.nv);
    std::cout << pad(m.name, width) << "  " << std::string(nv.size() < 2 ? 2 - nv.size() : 0, ' ') << nv << "  "
              << m.source << "\n";
  }
  return 0;
}

}  // namespace rbdgrad::cli
