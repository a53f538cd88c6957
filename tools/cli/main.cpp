// The rbdgrad command-line tool: `rbdgrad <command> [options]`.
#include <exception>
#include <iostream>
#include <string_view>

#include "eval_command.hpp"
#include "model_command.hpp"

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
};

void print_usage(std::ostream& os) {
  os << "usage: rbdgrad <command> [options]\n"
     << "       rbdgrad <command> --help | rbdgrad --help | rbdgrad --version\n\n"
     << "Rigid-body dynamics and their derivatives (rbdgrad " << RBDGRAD_VERSION << ").\n\ncommands:\n";
  for (const Command& c : kCommands) os << "  " << c.name << std::string(8 - c.name.size(), ' ') << c.summary << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    print_usage(std::cerr);
    return 2;
  }
  const std::string_view first = argv[1];
  if (first == "--help" || first == "-h" || first == "help") {
    print_usage(std::cout);
    return 0;
  }
  if (first == "--version") {
    std::cout << "rbdgrad " << RBDGRAD_VERSION << "\n";
    return 0;
  }
  for (const Command& c : kCommands) {
    if (c.name != first) continue;
    // library code returns errors as values; this catches what only the runtime throws (bad_alloc)
    try {
      return c.run(argc, argv, 2);
    } catch (const std::exception& e) {
      std::cerr << "rbdgrad " << c.name << ": internal error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "rbdgrad: unknown command '" << first << "'\n";
  print_usage(std::cerr);
  return 2;
}
