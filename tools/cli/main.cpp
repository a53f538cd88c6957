// The rbdgrad command-line tool: `rbdgrad [--server ADDR] <command> [options]`.
#include <exception>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

#include "compute_command.hpp"
#include "eval_command.hpp"
#include "calibrate_command.hpp"
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
    {"compute", rbdgrad::cli::kComputeSummary, rbdgrad::cli::run_compute_command},
};

void print_usage(std::ostream& os) {
  os << "usage: rbdgrad [--server ADDR] <command> [options]\n"
     << "       rbdgrad <command> --help | rbdgrad --help | rbdgrad --version\n\n"
     << "Rigid-body dynamics and their derivatives (rbdgrad " << RBDGRAD_VERSION << ").\n"
     << "info, calibrate, models, scenes and compute talk to the daemon rbdgradd at --server (default\n"
     << "127.0.0.1:50051; unix:/tmp/rbdgradd.sock is faster on the same host); eval and model compute\n"
     << "in-process.\n\ncommands:\n";
  for (const Command& c : kCommands) os << "  " << c.name << std::string(11 - c.name.size(), ' ') << c.summary << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  // `--server ADDR` may come before the command: it is handed to the command as its own option
  // (so that giving it on both sides is the command's "given twice" error)
  std::vector<const char*> global_server;
  int at = 1;
  while (at < argc && std::string_view(argv[at]).substr(0, 8) == "--server") {
    const std::string_view arg = argv[at];
    if (arg == "--server" && at + 1 < argc) {
      global_server = {argv[at], argv[at + 1]};
      at += 2;
    } else if (arg.substr(0, 9) == "--server=") {
      global_server = {argv[at]};
      at += 1;
    } else {
      std::cerr << "rbdgrad: option '--server' needs a value (ADDR)\n";
      print_usage(std::cerr);
      return 2;
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
