// rbdgradd, the rbdgrad daemon. Until the service lands (see the issues) it loads its model, reports
// the in-process CPU backend ready, and waits for SIGINT/SIGTERM.
#include <pthread.h>

#include <csignal>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include <spdlog/spdlog.h>

#include "args.hpp"
#include "model_source.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/model.hpp"

namespace {

constexpr rbdgrad::cli::OptionSpec kOptions[] = {
    {"model", "NAME|PATH", "embedded robot (hyq, iiwa14, panda, talos_reduced) or URDF file; default iiwa14"},
    {"once", "", "load the model, log its summary and exit (a start-up check)"},
    {"version", "", "print the version"},
    {"help", "", "show this help"},
};

void print_help(std::ostream& os) {
  os << "usage: rbdgradd [--model NAME|PATH] [--once]\n\n"
     << "The rbdgrad daemon (stub): loads the model and waits for SIGINT/SIGTERM.\n\noptions:\n"
     << rbdgrad::cli::format_options(kOptions);
}

// The stop signals are blocked from the start and taken with sigwait: no async-signal-safe handler
// is needed, threads started later inherit the mask, and a signal during start-up is not lost (it
// is taken once the daemon is ready, for a clean exit 0).
sigset_t stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

int wait_for_stop_signal(const sigset_t& set) {
  int signal = 0;
  if (sigwait(&set, &signal) != 0) return -1;
  return signal;
}

}  // namespace

int main(int argc, char** argv) {
  const sigset_t stop = stop_signals();
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  rbdgrad::cli::Args args;
  if (std::string error = rbdgrad::cli::Args::parse(kOptions, argc, argv, 1, args); !error.empty()) {
    std::cerr << "rbdgradd: " << error << "\n";
    print_help(std::cerr);
    return 2;
  }
  if (args.has("help")) {
    print_help(std::cout);
    return 0;
  }
  if (args.has("version")) {
    std::cout << "rbdgradd " << RBDGRAD_VERSION << "\n";
    return 0;
  }

  spdlog::info("rbdgradd {} starting", RBDGRAD_VERSION);
  const std::string spec = args.value_or("model", rbdgrad::kDefaultRobot);
  rbdgrad::Model model;
  if (rbdgrad::Status st = rbdgrad::cli::load_model(spec, std::nullopt, model); !st) {
    spdlog::error("{}", st.to_string());
    return 1;
  }
  // one log record per summary line, so each carries the timestamp prefix
  std::istringstream summary(rbdgrad::model_summary(model));
  for (std::string line; std::getline(summary, line);) spdlog::info("{}", line);
  spdlog::info("backend cpu: ready (in-process core library)");
  if (args.has("once")) return 0;

  const int signal = wait_for_stop_signal(stop);
  spdlog::info("shutting down (signal {})", signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "?");
  return 0;
}
