// rbdgradd, the rbdgrad daemon: serves the Dynamics gRPC service (server/daemon.hpp) until
// SIGINT/SIGTERM, then stops gracefully. Configuration: built-in defaults, then the YAML file of
// --config (configs/default.yaml documents every field), then the flags.
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <spdlog/spdlog.h>

#include "args.hpp"
#include "config.hpp"
#include "daemon.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "ready_file.hpp"
#include "stop_signals.hpp"

#ifndef RBDGRAD_PLUGIN_INSTALL_DIR_REL
#error "RBDGRAD_PLUGIN_INSTALL_DIR_REL must name the installed plugins' folder relative to the installed binary"
#endif
#ifndef RBDGRAD_PLUGIN_BUILD_DIR_REL
#error "RBDGRAD_PLUGIN_BUILD_DIR_REL must name build/plugins relative to the binary in the build tree"
#endif

namespace {

namespace server = rbdgrad::server;

constexpr rbdgrad::cli::OptionSpec kOptions[] = {
    {"config", "FILE", "YAML configuration (configs/default.yaml documents every field); default: built-in defaults"},
    {"listen", "HOST:PORT", "TCP address, overrides listen.tcp (port 0 = any free port; \"\" = no TCP)"},
    {"unix-socket", "PATH", "Unix socket, overrides listen.unix_socket (\"\" = none)"},
    {"workers", "N", "threads of the CPU backend (0 = hardware concurrency), overrides workers"},
    {"max-states", "N", "most states per request, overrides limits.max_states_per_request"},
    {"log-level", "LEVEL", "trace, debug, info, warn or error, overrides log_level"},
    {"model", "NAME|PATH", "serve only this model: an embedded robot (hyq, iiwa14, panda, talos_reduced) or a URDF file"},
    {"ready-file", "PATH", "once serving, write the bound addresses there (\"tcp HOST:PORT\", \"unix PATH\", one a line)"},
    {"once", "", "load the models and backends, log them and exit (a start-up check)"},
    {"version", "", "print the version"},
    {"help", "", "show this help"},
};

// flags that server/config.hpp's apply_flag_overrides applies on top of the file
constexpr const char* kConfigFlags[] = {"listen", "unix-socket", "workers", "max-states", "log-level"};

void print_help(std::ostream& os) {
  os << "usage: rbdgradd [--config FILE] [options]\n\n"
     << "The rbdgrad daemon: serves batched rigid-body dynamics and gradients over gRPC until\n"
     << "SIGINT/SIGTERM. Flags override the configuration file.\n\noptions:\n"
     << rbdgrad::cli::format_options(kOptions);
}

// A built-in backend's plugin ("cpu" -> librbdgrad_cpu.so): the installed layout (<prefix>/lib/rbdgrad
// next to <prefix>/bin), else the build tree's (build/plugins/cpu next to build/server), both
// relative to this executable. When neither exists, the installed path: loading it then fails with
// a log line that names the place it should be.
std::string builtin_plugin_path(const std::string& name) {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "";
  const std::filesystem::path dir = exe.parent_path();
  const std::string file = "librbdgrad_" + name + ".so";
  const std::filesystem::path installed = dir / RBDGRAD_PLUGIN_INSTALL_DIR_REL / file;
  const std::filesystem::path built = dir / RBDGRAD_PLUGIN_BUILD_DIR_REL / name / file;
  if (std::filesystem::exists(installed, ec)) return installed.lexically_normal().string();
  if (std::filesystem::exists(built, ec)) return built.lexically_normal().string();
  return installed.lexically_normal().string();
}

spdlog::level::level_enum spdlog_level(server::LogLevel level) {
  switch (level) {
    case server::LogLevel::kTrace: return spdlog::level::trace;
    case server::LogLevel::kDebug: return spdlog::level::debug;
    case server::LogLevel::kInfo: return spdlog::level::info;
    case server::LogLevel::kWarn: return spdlog::level::warn;
    case server::LogLevel::kError: return spdlog::level::err;
  }
  return spdlog::level::info;
}

// --model NAME|PATH: an embedded robot by its name, else a URDF file named after its stem
server::ModelConfig model_from_flag(const std::string& spec) {
  if (!rbdgrad::embedded_robot_urdf(spec).empty()) return {spec, "", spec, std::nullopt, {}};
  std::string name = std::filesystem::path(spec).stem().string();
  return {name.empty() ? spec : name, spec, "", std::nullopt, {}};
}

}  // namespace

int main(int argc, char** argv) {
  // a signal during start-up is taken once the daemon serves, for a clean exit 0
  const sigset_t stop = rbdgrad::cli::block_stop_signals();
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

  // defaults, then the file, then the flags
  server::ServerConfig config;
  std::string source = "built-in defaults";
  if (const std::string* path = args.value("config")) {
    if (rbdgrad::Status s = server::load_config_file(*path, config); !s) {
      std::cerr << "rbdgradd: " << s.message() << "\n";
      return 1;
    }
    source = "file " + *path;
  }
  std::vector<std::string> overrides;
  for (const char* flag : kConfigFlags) {
    if (const std::string* value = args.value(flag)) {
      overrides.push_back(std::string("--") + flag);
      overrides.push_back(*value);
    }
  }
  if (rbdgrad::Status s = server::apply_flag_overrides(overrides, config); !s) {
    std::cerr << "rbdgradd: " << s.message() << "\n";
    print_help(std::cerr);
    return 2;
  }
  if (const std::string* spec = args.value("model")) {
    config.models = {model_from_flag(*spec)};
    overrides.push_back("--model");
    overrides.push_back(*spec);
  }
  spdlog::set_level(spdlog_level(config.log_level));

  spdlog::info("rbdgradd {} starting", RBDGRAD_VERSION);
  std::string flags;
  for (const std::string& o : overrides) flags += " " + (o.empty() ? std::string("\"\"") : o);
  spdlog::info("config: {}{}", source, flags.empty() ? "" : ", flags" + flags);
  std::istringstream described(server::describe(config));
  for (std::string line; std::getline(described, line);) spdlog::debug("config: {}", line);

  server::DaemonOptions options;
  options.config = config;
  options.cpu_plugin_path = builtin_plugin_path("cpu");
  // loaded only when built or installed; without a GPU or an FPGA they report themselves unavailable
  options.optional_plugin_paths = {builtin_plugin_path("cuda"), builtin_plugin_path("fpga")};
  options.pool.inline_max_states = static_cast<std::uint64_t>(config.inline_max_states);
  std::unique_ptr<server::Daemon> daemon;
  if (rbdgrad::Status s = server::Daemon::create(std::move(options), daemon); !s) {
    spdlog::error("{}", s.to_string());
    return 1;
  }
  if (args.has("once")) return 0;

  if (rbdgrad::Status s = daemon->start(); !s) {
    spdlog::error("{}", s.to_string());
    return 1;
  }
  const std::string* ready_file = args.value("ready-file");
  if (ready_file != nullptr) {
    if (rbdgrad::Status s = server::write_ready_file(*ready_file, daemon->addresses()); !s) {
      spdlog::error("{}", s.to_string());
      daemon->stop();
      return 1;
    }
  }
  spdlog::info("serving {} model(s) on {} backend(s); SIGINT or SIGTERM stops", daemon->models().size(),
               daemon->backends().ready_count());

  const int signal = rbdgrad::cli::wait_for_stop_signal(stop);
  spdlog::info("shutting down (signal {}): finishing the requests in flight",
               signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "?");
  daemon->stop(/*for_exit=*/true);
  // the addresses are no longer served
  if (ready_file != nullptr) std::remove(ready_file->c_str());
  spdlog::info("stopped");
  return 0;
}
