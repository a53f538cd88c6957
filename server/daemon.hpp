// The daemon as an object: what rbdgradd's main runs and what the tests start in-process. From a
// ServerConfig it loads the models and backends (one log line per step), then serves the Dynamics
// service, the standard health service and server reflection over TCP and a Unix socket, and stops
// gracefully.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/server.h>

#include "access_control.hpp"
#include "backend_pool.hpp"
#include "coalescer.hpp"
#include "config.hpp"
#include "dynamics_service.hpp"
#include "listen_address.hpp"
#include "metrics.hpp"
#include "model_registry.hpp"
#include "scene_registrar.hpp"
#include "scheduler.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

struct DaemonOptions {
  ServerConfig config;
  // The built-in CPU backend (main looks next to its binary); empty = none besides config.plugins.
  std::string cpu_plugin_path;
  // The CUDA and FPGA plugins next to the binary: loaded when present (BackendPool::Options).
  std::vector<std::string> optional_plugin_paths;
  // How long stop() lets in-flight requests finish before cancelling them. Default 10 s.
  std::chrono::milliseconds shutdown_grace{10'000};
  // How requests reach the plugin instances (inline threshold).
  InstancePool::Options pool;
};

class Daemon {
 public:
  /// Checks the security settings (check_security) and reads the TLS files and the tokens file
  /// (errors name the file), loads the configured models (any failure is fatal: the error names the model) and the
  /// backends (a missing or broken plugin is logged and skipped; unavailable when none is ready),
  /// then calibrates the scheduler (config.scheduler). Logs each model's summary, each backend's
  /// state and each latency model, and the message size limit (derived from the models when
  /// limits.max_message_bytes is 0). Serves nothing yet.
  static Status create(DaemonOptions options, std::unique_ptr<Daemon>& out);

  /// Stops (as stop()) if still serving.
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Starts serving on config.listen (TCP "host:port", port 0 = an ephemeral one, with TLS when
  /// configured; the Unix socket, always plaintext, after removing a stale socket file). Logs
  /// every address. Errors: invalid_argument when no
  /// address is configured, failed_precondition when one cannot be bound (the socket of a live
  /// daemon is never taken over).
  Status start();

  /// The addresses served, with the bound TCP port; empty before start().
  const std::vector<ListenAddress>& addresses() const noexcept { return addresses_; }
  /// The bound TCP port; 0 before start() or without TCP.
  int tcp_port() const noexcept { return tcp_port_; }

  /// Graceful stop: reports NOT_SERVING on the health service, refuses new compute requests
  /// (UNAVAILABLE), lets the accepted ones finish and their responses go out (streams end after
  /// their last response), then stops listening and closes the connections; whatever is left
  /// after shutdown_grace is cancelled. Removes the daemon's socket file. Idempotent; not
  /// concurrent with start().
  /// With `for_exit` (the process ends next), gRPC's server object is left to the process's end
  /// instead of destroyed: on a 16-core machine its destructor waited 10 s after requests had
  /// finished on instance-pool threads (a gRPC executor thread sat in epoll_wait meanwhile).
  void stop(bool for_exit = false);

  const ModelRegistry& models() const noexcept { return models_; }
  const BackendPool& backends() const noexcept { return *backends_; }
  const Scheduler& scheduler() const noexcept { return *scheduler_; }
  const Metrics& metrics() const noexcept { return *metrics_; }
  const DynamicsService& service() const noexcept { return *service_; }
  /// The largest message accepted or sent: limits.max_message_bytes, or derived from the models.
  std::int64_t max_message_bytes() const noexcept { return max_message_bytes_; }

 private:
  explicit Daemon(DaemonOptions options) : options_(std::move(options)) {}

  DaemonOptions options_;
  ModelRegistry models_;
  std::unique_ptr<BackendPool> backends_;
  std::unique_ptr<Scheduler> scheduler_;
  std::unique_ptr<Metrics> metrics_;  // before the service, which records into it
  // the PEM files of config.tls, read at create
  std::string tls_cert_pem_, tls_key_pem_, tls_client_ca_pem_;
  std::int64_t max_message_bytes_ = 0;
  std::unique_ptr<AccessControl> access_;  // before the service and the server, which use it
  std::unique_ptr<SceneRegistrar> registrar_;  // before the service, which registers through it
  std::unique_ptr<DynamicsService> service_;
  // after the service: destroyed first, it hands what it holds to the pools (the daemon has
  // drained by then)
  std::unique_ptr<Coalescer> coalescer_;
  std::vector<ListenAddress> addresses_;
  int tcp_port_ = 0;
  ino_t socket_inode_ = 0;  // our socket file, removed at stop
  std::unique_ptr<grpc::Server> server_;  // last: stopped and destroyed before the rest
};

/// Logs a multi-line text as one record per line (each with its timestamp).
void log_lines(const std::string& text);

}  // namespace rbdgrad::server
