// Start-up (models, backends, listeners) and graceful stop of the daemon.
#include "daemon.hpp"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>
#include <utility>

#include <spdlog/spdlog.h>

#include "message_size.hpp"
#include "unix_socket.hpp"

#ifndef RBDGRAD_VERSION
#define RBDGRAD_VERSION "unknown"
#endif

namespace rbdgrad::server {
namespace {

// How long gRPC's Shutdown waits for calls other than compute ones before it cancels them.
constexpr std::chrono::milliseconds kCloseGrace{200};

std::string backend_line(const BackendState& b) {
  std::ostringstream os;
  os << "backend " << b.name << ": ready ";
  if (b.name != b.kind) os << "(" << b.kind << " plugin) ";
  // the CPU plugin runs the core library inside the daemon's process
  if (b.kind == "cpu") os << "(in-process core library) ";
  // a stand-in says so first: "ready (csim: ...)" must not read as hardware
  if (!b.description.mode.empty()) os << "(" << b.description.mode << ") ";
  if (!b.description.device.empty()) os << "on " << b.description.device << " ";
  // e.g. which CUDA kernel runs, for the first model
  if (!b.description.detail.empty()) os << "[" << b.description.detail << "] ";
  os << "from " << b.path << ": version " << (b.info.version.empty() ? "?" : b.info.version) << ", precisions "
     << precision_list(b.info.precisions) << ", max_batch ";
  if (b.info.max_batch == 0) {
    os << "unlimited";
  } else {
    os << b.info.max_batch;
  }
  os << ", " << b.instances_per_model << " instance(s) per model";
  if (!b.options.empty()) os << " (" << b.options << ")";
  return os.str();
}

// "127.0.0.1:0" with port 41234 -> "127.0.0.1:41234"
std::string with_port(const std::string& address, int port) {
  const auto colon = address.rfind(':');
  return (colon == std::string::npos ? address : address.substr(0, colon)) + ":" + std::to_string(port);
}

// A PEM file of config.tls, whole; errors name the key and the file.
Status read_pem(const char* key, const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found(std::string(key) + ": cannot read '" + path + "': " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  out = text.str();
  // gRPC would only say "handshaker factory creation failed" much later
  if (out.find("-----BEGIN ") == std::string::npos)
    return invalid_argument(std::string(key) + ": '" + path + "' holds no PEM block (-----BEGIN ...)");
  return Status::ok();
}

}  // namespace

void log_lines(const std::string& text) {
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) spdlog::info("{}", line);
}

Status Daemon::create(DaemonOptions options, std::unique_ptr<Daemon>& out) {
  std::unique_ptr<Daemon> d(new Daemon(std::move(options)));
  const ServerConfig& cfg = d->options_.config;

  // before anything slow: a daemon that must not start should say so at once
  if (Status s = check_security(cfg); !s) return s;
  if (cfg.tls.enabled()) {
    if (Status s = read_pem("tls.cert_file", cfg.tls.cert_file, d->tls_cert_pem_); !s) return s;
    if (Status s = read_pem("tls.key_file", cfg.tls.key_file, d->tls_key_pem_); !s) return s;
    if (!cfg.tls.client_ca_file.empty()) {
      if (Status s = read_pem("tls.client_ca_file", cfg.tls.client_ca_file, d->tls_client_ca_pem_); !s) return s;
    }
  }
  std::vector<ClientToken> tokens;
  if (!cfg.auth.tokens_file.empty()) {
    if (Status s = load_tokens_file(cfg.auth.tokens_file, tokens); !s) return s;
    std::string names;
    for (const ClientToken& t : tokens) names += (names.empty() ? "" : ", ") + t.name;
    spdlog::info("auth: {} client token(s) from {} ({}); every call but the health service needs one", tokens.size(),
                 cfg.auth.tokens_file, names);
  }

  // places for the scenes registered later (RegisterScene), so that the registry never moves
  if (Status s = ModelRegistry::load(cfg.models, cfg.scenes, d->models_,
                                     static_cast<std::size_t>(cfg.limits.max_registered_scenes));
      !s)
    return s;
  for (const auto& m : d->models_.models()) {
    std::string summary = m->summary;
    // the name clients use, when it is not the robot's own
    const auto first_line_end = std::min(summary.find('\n'), summary.size());
    if (m->scene) summary.insert(first_line_end, " (scene '" + m->name + "', " + m->origin + ")");
    else if (m->name != m->model.name) summary.insert(first_line_end, " (served as '" + m->name + "')");
    log_lines(summary);
  }

  BackendPool::Options backend_options;
  backend_options.cpu_plugin_path = d->options_.cpu_plugin_path;
  backend_options.optional_plugin_paths = d->options_.optional_plugin_paths;
  backend_options.plugins = cfg.plugins;
  backend_options.workers = cfg.workers;
  backend_options.pool = d->options_.pool;
  d->backends_ = BackendPool::create(backend_options, d->models_);
  for (const BackendState& b : d->backends_->backends()) {
    if (b.ready) {
      spdlog::info("{}", backend_line(b));
      for (const std::string& problem : b.model_problems) spdlog::warn("backend {}: cannot serve {}", b.name, problem);
    } else {
      spdlog::warn("backend {}: unavailable: {}", b.name, b.reason);
    }
  }
  // the first instance speaks for its backend above; a model whose instances run otherwise (a
  // scene's CUDA kernel with its stages fixed) says so here
  for (const auto& m : d->models_.models())
    for (const std::string& line : d->backends_->model_details(*m)) spdlog::info("model '{}' on {}", m->name, line);
  if (d->backends_->ready_count() == 0) return unavailable("no backend is available: nothing can serve requests");

  d->scheduler_ = std::make_unique<Scheduler>(*d->backends_, d->models_, cfg.scheduler);
  if (cfg.scheduler.backend_timeout_ms != 0)
    spdlog::info("backend calls are bounded at {}: past it a request runs again on the next best backend",
                 cfg.scheduler.backend_timeout_ms > 0 ? std::to_string(cfg.scheduler.backend_timeout_ms) + " ms"
                                                      : std::string("max(1 s, 20x their prediction)"));
  d->scheduler_->calibrate(false, [](const std::string& line) { spdlog::info("{}", line); });
  for (const auto& m : d->models_.models()) {
    std::string text;
    for (const auto& [n, backend] : d->scheduler_->crossovers(*m, 0, std::uint64_t{1} << 20))
      text += (text.empty() ? "" : ", ") + backend + " from N = " + std::to_string(n);
    if (!text.empty()) spdlog::info("routing of model '{}' ({} policy): fastest {}", m->name, cfg.scheduler.policy, text);
  }
  Daemon* self = d.get();
  auto queues = [self] {
    std::vector<QueueSample> samples;
    for (const BackendState& b : self->backends_->backends()) {
      for (const auto& m : self->models_.models()) {
        const InstancePool* pool = self->backends_->pool(b.name, *m);
        if (pool == nullptr) continue;
        const PoolLoad load = pool->load();
        samples.push_back({b.name, m->name, load.queued, load.running, load.pending_us * 1e-6});
      }
    }
    return samples;
  };
  auto in_flight = [self]() -> std::int64_t { return self->service_ ? self->service_->in_flight() : 0; };
  if (Status s = Metrics::create(cfg.metrics_listen, queues, in_flight, d->metrics_); !s) return s;
  if (!cfg.metrics_listen.empty())
    spdlog::info("metrics: http://{}:{}/metrics", cfg.metrics_listen.substr(0, cfg.metrics_listen.rfind(':')),
                 d->metrics_->port());
  if (cfg.limits.max_queue_delay_us > 0) {
    d->coalescer_ = std::make_unique<Coalescer>(std::chrono::microseconds(cfg.limits.max_queue_delay_us),
                                                static_cast<std::uint64_t>(cfg.scheduler.preferred_batch_states));
    spdlog::info("dynamic batching: requests under {} states wait up to {} us for others", cfg.scheduler.preferred_batch_states,
                 cfg.limits.max_queue_delay_us);
  }
  LimitsConfig limits = cfg.limits;
  if (limits.max_message_bytes == 0) {
    std::string how;
    limits.max_message_bytes = derived_max_message_bytes(d->models_, limits.max_states_per_request, how);
    if (limits.max_message_bytes == INT_MAX) spdlog::warn("limits.max_message_bytes: {} bytes, {}", limits.max_message_bytes, how);
    else spdlog::info("limits.max_message_bytes: {} bytes, {}", limits.max_message_bytes, how);
  } else {
    spdlog::info("limits.max_message_bytes: {} bytes, as configured", limits.max_message_bytes);
  }
  d->max_message_bytes_ = limits.max_message_bytes;
  d->access_ = std::make_unique<AccessControl>(std::move(tokens), limits, d->metrics_.get());
  if (d->access_->limits_enabled()) {
    const double rate = limits.client_requests_per_second;
    const double burst = limits.client_burst > 0 ? static_cast<double>(limits.client_burst) : std::max(1.0, rate);
    spdlog::info("per-client limits ({}): {}, {} compute requests in flight",
                 d->access_->auth_enabled() ? "clients by token name" : "clients by peer address",
                 rate > 0 ? fmt::format("{:g} requests/s (burst {:g})", rate, burst) : std::string("any request rate"),
                 limits.client_max_concurrent > 0 ? std::to_string(limits.client_max_concurrent) : "any number of");
  }
  // a registered scene is no larger than its model: the message size above holds for it too
  d->registrar_ = std::make_unique<SceneRegistrar>(d->models_, *d->backends_, *d->scheduler_,
                                                   static_cast<std::size_t>(cfg.limits.max_registered_scenes));
  d->service_ = std::make_unique<DynamicsService>(d->models_, *d->backends_, *d->scheduler_, limits,
                                                  RBDGRAD_VERSION, cfg.fixed_point_fallback, d->metrics_.get(),
                                                  d->coalescer_.get(), d->access_.get(), d->registrar_.get());
  out = std::move(d);
  return Status::ok();
}

Daemon::~Daemon() {
  stop();
  // The pools go before the scheduler: a backend call that timed out may still be running on a
  // pool thread (its request answered elsewhere), and when it returns it tells the scheduler.
  // What uses the pools goes first: the coalescer hands what it holds to them, the service (and
  // its watchdog) and the metrics read them.
  coalescer_.reset();
  service_.reset();
  metrics_.reset();
  backends_.reset();
}

Status Daemon::start() {
  if (server_) return failed_precondition("the daemon is already serving");
  const ListenConfig& listen = options_.config.listen;
  if (listen.tcp.empty() && listen.unix_socket.empty()) {
    return invalid_argument("no listen address: set listen.tcp and/or listen.unix_socket");
  }
  if (!listen.unix_socket.empty()) {
    if (Status s = free_unix_socket_path(listen.unix_socket); !s) return s;
  }

  // process-wide switches, read when the server is built
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();

  grpc::ServerBuilder builder;
  int port = 0;
  const TlsConfig& tls = options_.config.tls;
  std::string tcp_mode = "plaintext";
  if (!listen.tcp.empty()) {
    std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
    if (tls.enabled()) {
      grpc::SslServerCredentialsOptions ssl;
      ssl.pem_key_cert_pairs.push_back({tls_key_pem_, tls_cert_pem_});
      if (!tls.client_ca_file.empty()) {
        ssl.pem_root_certs = tls_client_ca_pem_;
        ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
        tcp_mode = "mutual TLS: clients need a certificate signed by " + tls.client_ca_file;
      } else {
        tcp_mode = "TLS";
      }
      credentials = grpc::SslServerCredentials(ssl);
    } else if (!is_loopback_address(listen.tcp)) {
      // check_security let it through: listen.insecure is set
      spdlog::warn("tcp {} is not a loopback address and serves plaintext (listen.insecure: true)", listen.tcp);
    }
    builder.AddListeningPort(listen.tcp, credentials, &port);
  }
  // plaintext: the socket file's permissions say who may connect
  if (!listen.unix_socket.empty()) {
    builder.AddListeningPort("unix:" + listen.unix_socket, grpc::InsecureServerCredentials());
  }
  if (access_->auth_enabled()) {
    // the Dynamics handlers check tokens themselves; this guards the rest but health (reflection)
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
    interceptors.push_back(std::make_unique<AuthInterceptorFactory>(*access_));
    builder.experimental().SetInterceptorCreators(std::move(interceptors));
  }
  const auto max_bytes = static_cast<int>(max_message_bytes_);
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  // gRPC sets SO_REUSEPORT by default: a second daemon on the same port would then share it silently
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  // The reflection service is a synchronous one: its polling threads wait on their queues with this
  // timeout, and destroying the server waits for them, up to the default 10 s (measured on 16
  // cores after a request had finished on an instance-pool thread). Idle pollers now wake every
  // 100 ms, which costs nothing measurable.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::CQ_TIMEOUT_MSEC, 100);
  builder.RegisterService(service_.get());

  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  std::string where = listen.tcp.empty() ? "" : "tcp " + listen.tcp;
  if (!listen.unix_socket.empty()) where += (where.empty() ? "" : ", ") + std::string("unix ") + listen.unix_socket;
  if (!server) return failed_precondition("cannot listen on " + where + " (gRPC's log above says why)");
  if (!listen.tcp.empty() && port == 0) {
    server->Shutdown();
    return failed_precondition("cannot listen on tcp " + listen.tcp + " (in use, or not a local address)");
  }

  addresses_.clear();
  if (!listen.tcp.empty()) {
    tcp_port_ = port;
    addresses_.push_back({"tcp", with_port(listen.tcp, port)});
  }
  if (!listen.unix_socket.empty()) {
    socket_inode_ = socket_inode(listen.unix_socket);
    addresses_.push_back({"unix", listen.unix_socket});
  }
  server_ = std::move(server);
  for (const ListenAddress& a : addresses_)
    spdlog::info("listening on {} ({})", a.text(), a.kind == "tcp" ? tcp_mode : "plaintext");
  return Status::ok();
}

void Daemon::stop(bool for_exit) {
  if (!server_) return;
  // clients that watch health learn first; then streams are told; then gRPC stops accepting and
  // waits for the calls under way (cancelling what is left at the deadline)
  if (grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService()) health->Shutdown();
  service_->begin_shutdown();
  // Our own calls are drained first: gRPC's Shutdown(deadline) also waits until every client
  // has closed its connection, and an idle client (no call, nothing polling its socket) never
  // reads the GOAWAY, so Shutdown would sit out the whole deadline. Polled: stopping is rare,
  // and the request path stays free of notifications.
  const auto began = std::chrono::steady_clock::now();
  const auto deadline = began + options_.shutdown_grace;
  while (!service_->drained() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!service_->drained()) {
    spdlog::warn("{} compute request(s) still in flight after the shutdown grace of {} ms: cancelling them",
                 service_->in_flight(), options_.shutdown_grace.count());
  }
  // a moment for calls outside the Dynamics compute path (metadata, health) to answer; then the
  // remaining connections are closed
  const auto drained = std::chrono::steady_clock::now();
  server_->Shutdown(std::chrono::system_clock::now() + kCloseGrace);
  server_->Wait();
  const auto ms = [](auto d) { return std::chrono::duration_cast<std::chrono::milliseconds>(d).count(); };
  const auto closed = std::chrono::steady_clock::now();
  if (for_exit) {
    (void)server_.release();  // deliberately not destroyed: see stop()'s comment
    spdlog::info("requests drained in {} ms, connections closed in {} ms", ms(drained - began), ms(closed - drained));
  } else {
    server_.reset();
    spdlog::info("requests drained in {} ms, connections closed in {} ms, server released in {} ms",
                 ms(drained - began), ms(closed - drained), ms(std::chrono::steady_clock::now() - closed));
  }
  if (!options_.config.listen.unix_socket.empty()) remove_own_socket(options_.config.listen.unix_socket, socket_inode_);
  addresses_.clear();
  tcp_port_ = 0;
}

}  // namespace rbdgrad::server
