// A real rbdgradd process for integration tests: started on an ephemeral loopback port and a Unix
// socket in a private temporary directory, found through its --ready-file, stopped with a signal.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace rbdgrad::testing {

class DaemonProcess {
 public:
  /// Starts `binary` with `--config <yaml>` (when `config_yaml` is not empty) and the listen flags
  /// (an ephemeral TCP port unless `extra_args` has a --listen),
  /// then waits up to `timeout` for the ready file. Throws std::runtime_error with the daemon's log
  /// when it exits or times out first.
  DaemonProcess(const std::string& binary, const std::string& config_yaml, std::vector<std::string> extra_args = {},
                std::chrono::seconds timeout = std::chrono::seconds(60)) {
    char tmpl[] = "/tmp/rbdgrad-it-XXXXXX";
    if (!mkdtemp(tmpl)) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    socket_path_ = dir_ + "/rbdgradd.sock";
    log_path_ = dir_ + "/rbdgradd.log";
    const std::string ready = dir_ + "/ready";
    std::vector<std::string> args = {binary};
    if (!config_yaml.empty()) {
      std::ofstream(dir_ + "/config.yaml") << config_yaml;
      args.insert(args.end(), {"--config", dir_ + "/config.yaml"});
    }
    // an ephemeral loopback port unless extra_args name the address (a daemon started again on its port)
    if (std::find(extra_args.begin(), extra_args.end(), "--listen") == extra_args.end())
      args.insert(args.end(), {"--listen", "127.0.0.1:0"});
    args.insert(args.end(), {"--unix-socket", socket_path_, "--ready-file", ready});
    args.insert(args.end(), extra_args.begin(), extra_args.end());

    // the daemon's stdout and stderr go to a log file, read back when something fails
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int rc = posix_spawn(&pid_, binary.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) throw std::runtime_error("cannot start " + binary + ": " + std::strerror(rc));

    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!std::filesystem::exists(ready)) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("rbdgradd exited before it was ready; log:\n" + log());
      }
      if (std::chrono::steady_clock::now() > deadline) {
        kill_now();
        throw std::runtime_error("rbdgradd not ready after timeout; log:\n" + log());
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::ifstream in(ready);
    for (std::string kind, address; in >> kind >> address;) {
      if (kind == "tcp") tcp_address_ = address;
      if (kind == "unix") unix_address_ = "unix:" + address;
    }
    if (tcp_address_.empty()) throw std::runtime_error("ready file names no tcp address; log:\n" + log());
  }

  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;
  ~DaemonProcess() {
    kill_now();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  const std::string& tcp_address() const { return tcp_address_; }    // "127.0.0.1:41234"
  const std::string& unix_address() const { return unix_address_; }  // "unix:/tmp/.../rbdgradd.sock"
  const std::string& socket_path() const { return socket_path_; }
  pid_t pid() const { return pid_; }

  /// Sends `signal` (0: none, only wait), waits up to `timeout` for the exit and returns the wait
  /// status (nullopt on timeout, after which the process is killed).
  std::optional<int> stop(int signal = SIGTERM, std::chrono::seconds timeout = std::chrono::seconds(30)) {
    if (pid_ <= 0) return std::nullopt;
    ::kill(pid_, signal);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return status;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    kill_now();
    return std::nullopt;
  }

  std::string log() const {
    std::ifstream in(log_path_);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

 private:
  void kill_now() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  pid_t pid_ = -1;
  std::string dir_, socket_path_, log_path_, tcp_address_, unix_address_;
};

}  // namespace rbdgrad::testing
