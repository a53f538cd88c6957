// The rbdgrad command-line tool: `rbdgrad [--server ADDR] <command> [options]`.
#include <exception>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

#include "compute_command.hpp"
#include "eval_command.hpp"
#include "calibrate_command.hpp"
#include "health_command.hpp"
#include "info_command.hpp"
#include "model_command.hpp"
#include "models_command.hpp"
#include "scenes_command.hpp"

namespace {

struct Command {
  std::string_view name;
  const char* summary;
  int (*run)(int argc, const char* const* argv, int first);  // argv[first..] are the command's options
};

// One row per subcommand; the usage text is built from this table.
constexpr Command kCommands[] = {
    {"eval", rbdgrad::cli::kEvalSummary, rbdgrad::cli::run_eval_command},
    {"model", rbdgrad::cli::kModelSummary, rbdgrad::cli::run_model_command},
    {"info", rbdgrad::cli::kInfoSummary, rbdgrad::cli::run_info_command},
    {"calibrate", rbdgrad::cli::kCalibrateSummary, rbdgrad::cli::run_calibrate_command},
    {"models", rbdgrad::cli::kModelsSummary, rbdgrad::cli::run_models_command},
    {"scenes", rbdgrad::cli::kScenesSummary, rbdgrad::cli::run_scenes_command},
    {"register-scene", rbdgrad::cli::kRegisterSceneSummary, rbdgrad::cli::run_register_scene_command},
    {"compute", rbdgrad::cli::kComputeSummary, rbdgrad::cli::run_compute_command},
    {"health", rbdgrad::cli::kHealthSummary, rbdgrad::cli::run_health_command},
};

// The connection's options, which may come before the command (each is handed to the command)
constexpr std::string_view kGlobalOptions[] = {"--server", "--tls-ca", "--tls-cert", "--tls-key", "--token-file"};

void print_usage(std::ostream& os) {
  os << "usage: rbdgrad [--server ADDR] [--tls-ca FILE] [--tls-cert FILE --tls-key FILE] [--token-file FILE]\n"
     << "               <command> [options]\n"
     << "       rbdgrad <command> --help | rbdgrad --help | rbdgrad --version\n\n"
     << "Rigid-body dynamics and their derivatives (rbdgrad " << RBDGRAD_VERSION << ").\n"
     << "info, calibrate, models, scenes, register-scene, compute and health talk to the daemon rbdgradd\n"
     << "at --server (default 127.0.0.1:50051; unix:/tmp/rbdgradd.sock is faster on the same host);\n"
     << "eval and model compute in-process.\n\ncommands:\n";
  // names of at most 15 characters, padded to 16 columns
  for (const Command& c : kCommands) os << "  " << c.name << std::string(16 - c.name.size(), ' ') << c.summary << "\n";
  os << "\nconnection options (before or after the command):\n"
     << "  --server ADDR       HOST:PORT or unix:PATH; default 127.0.0.1:50051\n"
     << "  --tls-ca FILE       TLS: the PEM CA certificate the server's certificate must chain to\n"
     << "  --tls-cert FILE     mutual TLS: this client's PEM certificate chain (with --tls-key)\n"
     << "  --tls-key FILE      mutual TLS: this client's PEM private key\n"
     << "  --token-file FILE   send the token in FILE as 'authorization: Bearer TOKEN' (auth.tokens_file)\n";
}

}  // namespace

int main(int argc, char** argv) {
  // The connection's options may come before the command: they are handed to the command as its
  // own options (so that giving one on both sides is the command's "given twice" error)
  std::vector<const char*> global_server;
  int at = 1;
  for (bool more = true; more && at < argc;) {
    more = false;
    const std::string_view arg = argv[at];
    for (std::string_view option : kGlobalOptions) {
      if (arg == option && at + 1 < argc) {
        global_server.insert(global_server.end(), {argv[at], argv[at + 1]});
        at += 2;
      } else if (arg.substr(0, option.size() + 1) == std::string(option) + "=") {
        global_server.push_back(argv[at]);
        at += 1;
      } else if (arg == option) {
        std::cerr << "rbdgrad: option '" << option << "' needs a value\n";
        print_usage(std::cerr);
        return 2;
      } else {
        continue;
      }
      more = true;
      break;
    }
  }
  if (at >= argc) {
    print_usage(std::cerr);
    return 2;
  }
  const std::string_view first = argv[at];
  if (global_server.empty() && (first == "--help" || first == "-h" || first == "help")) {
    print_usage(std::cout);
    return 0;
  }
  if (global_server.empty() && first == "--version") {
    std::cout << "rbdgrad " << RBDGRAD_VERSION << "\n";
    return 0;
  }
  for (const Command& c : kCommands) {
    if (c.name != first) continue;
    std::vector<const char*> args(argv, argv + 1);
    args.insert(args.end(), argv + at, argv + argc);
    args.insert(args.end(), global_server.begin(), global_server.end());
    // library code returns errors as values; this catches what only the runtime throws (bad_alloc)
    try {
      return c.run(static_cast<int>(args.size()), args.data(), 2);
    } catch (const std::exception& e) {
      std::cerr << "rbdgrad " << c.name << ": internal error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "rbdgrad: unknown command '" << first << "'\n";
  print_usage(std::cerr);
  return 2;
}
