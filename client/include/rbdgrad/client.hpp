// rbdgrad::Client, the C++ client of the rbdgrad service (the daemon rbdgradd): batched
// rigid-body dynamics and their gradients over gRPC, without any gRPC or protobuf type in the API.
//
//   rbdgrad::Client client("unix:/tmp/rbdgradd.sock");
//   rbdgrad::ComputeRequest req;
//   req.model = "iiwa14";
//   req.num_states = n;
//   req.outputs = rbdgrad::Output::kDqddDq | rbdgrad::Output::kDqddDqd;
//   req.q = q; req.qd = qd; req.u = tau;            // n x nv each, state-major
//   rbdgrad::ComputeResult r = client.compute(req);  // throws rbdgrad::ClientError
//   Eigen::MatrixXd g = r.dqdd_dq(0);                // a view; copy only if you keep it
//
// Calls: compute (sync: throwing, or returning an RpcStatus), compute_async (a std::future, or a
// callback on a gRPC thread; no thread per call), ComputeSession (one long-lived stream for a
// control loop: one request per step, responses in order, buffers reused), list_models,
// get_model, list_scenes, get_scene, register_scene, server_info, check_health. Every call has a
// deadline: its own timeout, else the client's default. ClientOptions::tls and bearer_token reach
// a daemon with TLS (or mutual TLS) and token authentication.
//
// Threads: a Client may be used from any number of threads at once (they share one channel: one
// connection per server). A ComputeSession is used by one thread at a time.
//
// Several servers: Client({"10.0.0.5:50050", "10.0.0.5:50051"}), a target that lists several
// addresses ("ipv4:10.0.0.5:50050,10.0.0.5:50051") or a DNS name with several records
// ("dns:///rbdgradd-headless.mpc.svc.cluster.local:50051") gives one channel with gRPC's
// round_robin policy: it connects to every address and sends each call to the next server that is
// up (ClientOptions::load_balancing).
//
// Retries (ClientOptions::retry): a unary call that fails with UNAVAILABLE (no server reachable,
// or the connection dropped during the call, e.g. a daemon killed) is sent again after a backoff
// with jitter, up to retry.max_attempts attempts in all and never past the call's deadline: its
// timeout covers every attempt and pause. With several servers round_robin sends the retry to a
// server that is up. Every unary Dynamics call is a pure function of its request (Compute,
// ListModels, GetModel, ListScenes, GetScene, GetServerInfo, and the health check) or idempotent
// (RegisterScene: the same definition twice is registered once), so sending it twice is
// harmless; calibrate() is not retried (its UNAVAILABLE means another calibration runs).
// Other codes are never retried. A ComputeSession is never retried or replayed: an error
// (UNAVAILABLE included) ends the session, and the caller opens a new one (which round_robin
// places on a server that is up) and decides what to send again. ComputeTimings::attempts and
// Client::retry_stats() tell how many attempts were made.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rbdgrad/client_export.hpp"
#include "rbdgrad/compute_result.hpp"
#include "rbdgrad/compute_types.hpp"
#include "rbdgrad/rpc_status.hpp"
#include "rbdgrad/service_info.hpp"

namespace rbdgrad {

// The daemon's default TCP address (loopback). The daemon also listens on the Unix socket
// kDefaultUnixSocketAddress, the faster transport for processes on the same host: prefer it there.
inline constexpr std::string_view kDefaultServerAddress = "127.0.0.1:50051";
inline constexpr std::string_view kDefaultUnixSocketAddress = "unix:/tmp/rbdgradd.sock";

// TLS towards a daemon whose TCP listener has it (rbdgradd's `tls` section). The files are read
// when the Client is constructed.
struct TlsOptions {
  // PEM CA certificate(s) the server's certificate must chain to. "" = gRPC's default roots.
  std::string ca_file;
  // The client's PEM certificate chain and private key, for a server that asks for mutual TLS
  // (tls.client_ca_file): both or neither.
  std::string cert_file;
  std::string key_file;
  // The name the server's certificate must carry when it is not the address's host (e.g. when
  // dialing an IP address). "" = the host of the address.
  std::string target_name_override;
};

// How calls that fail with UNAVAILABLE are retried. The pause before retry k (k = 1, 2, ...) is
// drawn uniformly from [(1 - jitter) * b, b], b = min(max_backoff, initial_backoff * multiplier^(k-1))
// (see retry_backoff); a retry whose pause would end past the call's deadline is not made.
struct RetryPolicy {
  // Attempts in all, the first included; 1 = no retry. Default 4.
  int max_attempts = 4;
  // Default 10 ms, then x2 per retry up to 1 s.
  std::chrono::nanoseconds initial_backoff = std::chrono::milliseconds(10);
  std::chrono::nanoseconds max_backoff = std::chrono::seconds(1);
  double multiplier = 2.0;  // >= 1
  // In [0, 1]: 1 = "full jitter" (a pause anywhere in [0, b]), 0 = exactly b. Default 1.
  double jitter = 1.0;
};

/// The pause before retry `retry` (1 = the first retry) for a uniform draw `u` in [0, 1):
/// b * (1 - jitter * u), b as in RetryPolicy. Exposed for tests and for callers that retry
/// sessions themselves.
RBDGRAD_CLIENT_EXPORT std::chrono::nanoseconds retry_backoff(const RetryPolicy& policy, int retry, double u) noexcept;

// gRPC's load-balancing policy of the client's channel.
enum class LoadBalancing {
  // round_robin for several addresses and for "ipv4:", "ipv6:" and "dns:" targets (a DNS name may
  // stand for several servers, e.g. a Kubernetes headless Service); pick_first (gRPC's default:
  // every call to the first address that answers) for one plain "host:port" or a "unix:" socket.
  kAuto,
  kPickFirst,
  kRoundRobin,
};

// What the retries did, counted over the client's life (every call and thread).
struct RetryStats {
  std::uint64_t retries = 0;  // attempts made after an UNAVAILABLE
  std::uint64_t gave_up = 0;  // calls that ended UNAVAILABLE: attempts used up or no time left
};

struct ClientOptions {
  // Deadline of a call that does not set its own timeout. Default 10 s.
  std::chrono::nanoseconds default_timeout = std::chrono::seconds(10);
  // Largest message sent or received, in bytes. Default 256 MiB. (The daemon's own limit is
  // derived from its models and largest batch unless configured; server_info() tells it.)
  std::int64_t max_message_bytes = std::int64_t{256} << 20;
  // false: a call fails at once with UNAVAILABLE when no server answers at the address.
  // true: a call waits for the server until its deadline (DEADLINE_EXCEEDED). Default false.
  bool wait_for_ready = false;
  // TLS; empty = plaintext (the default, and what a daemon's Unix socket speaks).
  std::optional<TlsOptions> tls;
  // Sent with every call as the metadata "authorization: Bearer <token>", for a daemon with
  // auth.tokens_file. "" = none (such a daemon answers UNAUTHENTICATED).
  std::string bearer_token;
  // Retries of unary calls after UNAVAILABLE (see RetryPolicy); {.max_attempts = 1} = none.
  RetryPolicy retry;
  // The channel's load-balancing policy; kAuto: see LoadBalancing.
  LoadBalancing load_balancing = LoadBalancing::kAuto;
};

struct SessionOptions {
  // Deadline of each step that does not set its own timeout; empty = ClientOptions::default_timeout.
  // A step past its deadline ends the session (DEADLINE_EXCEEDED).
  std::optional<std::chrono::nanoseconds> step_timeout;
  // Deadline of the whole stream from open_session; empty = none (a control loop runs for hours).
  std::optional<std::chrono::nanoseconds> lifetime;
};

// A ComputeStream for a control loop: each step sends one request and waits for its response
// (responses come in order). The request and response messages are reused from step to step, so
// a step allocates nothing once the sizes are stable. After an error the session is closed: the
// server ends the stream at the first failed request; open a new session to go on.
// Not thread-safe: one thread at a time.
class RBDGRAD_CLIENT_EXPORT ComputeSession {
 public:
  ComputeSession();  // a closed session; Client::open_session gives an open one
  ~ComputeSession();  // closes, as close() does
  ComputeSession(ComputeSession&&) noexcept;
  ComputeSession& operator=(ComputeSession&&) noexcept;
  ComputeSession(const ComputeSession&) = delete;
  ComputeSession& operator=(const ComputeSession&) = delete;

  /// Sends `req` and returns its result: a reference to the session's own result, valid until the
  /// next step or close. Throws ClientError (the server's code and message; FAILED_PRECONDITION
  /// when the session is closed).
  const ComputeResult& step(const ComputeRequest& req);
  /// Same without exceptions: fills `out` (reusing its buffers) and returns the status.
  RpcStatus step(const ComputeRequest& req, ComputeResult& out);

  /// Ends the stream: tells the server no more requests come and waits for its final status
  /// (bounded by the step timeout). Returns that status, or the error that ended the session.
  /// Further calls return the same status.
  RpcStatus close();
  bool is_open() const noexcept;

  struct State;

 private:
  friend class Client;
  explicit ComputeSession(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
  ComputeResult result_;  // what step(req) returns
};

class RBDGRAD_CLIENT_EXPORT Client {
 public:
  // Called once per asynchronous call, on a gRPC thread: keep it short (hand the result to your
  // own thread) and do not throw. `result` is valid only when `status` is ok.
  using ComputeCallback = std::function<void(RpcStatus status, ComputeResult result)>;

  /// \param address  a gRPC target: "127.0.0.1:50051", "localhost:50051", "unix:/path/to.sock".
  ///                 Connecting is lazy: the first call reports an unreachable server (or a
  ///                 failed TLS handshake) as UNAVAILABLE. Also a list: "ipv4:HOST:PORT,HOST:PORT",
  ///                 "ipv6:[ADDR]:PORT,...", or a "dns:///NAME:PORT" of several records (round_robin,
  ///                 see LoadBalancing). Constructing throws ClientError (INVALID_ARGUMENT) only
  ///                 when a file of options.tls cannot be read or options.retry is out of range
  ///                 (max_attempts < 1, a negative backoff, multiplier < 1, jitter outside [0, 1]).
  explicit Client(std::string address = std::string(kDefaultServerAddress), ClientOptions options = {});
  /// Several servers on one channel, round_robin over them (unless options.load_balancing says
  /// otherwise): each "IPV4:PORT" or "[IPV6]:PORT", all of one family (the target becomes
  /// "ipv4:A,B,..." / "ipv6:A,B,..."; address() returns it). One entry is taken as the constructor
  /// above takes it. For host names use one "dns:///NAME:PORT" target instead. Throws ClientError
  /// (INVALID_ARGUMENT) for an empty list, an entry that is not such an address (a "unix:" socket
  /// included) or mixed families, and as the constructor above.
  explicit Client(const std::vector<std::string>& addresses, ClientOptions options = {});
  /// The same, for Client({"127.0.0.1:50051", "127.0.0.1:50052"}) (Client{address} with one
  /// address stays the single-address client).
  Client(std::initializer_list<std::string> addresses, ClientOptions options = {});
  /// Waits for the asynchronous calls still in flight to complete (each by its deadline at the
  /// latest); their callbacks may still be running when it returns.
  ~Client();
  Client(Client&&) noexcept;
  Client& operator=(Client&&) noexcept;
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const std::string& address() const noexcept;
  const ClientOptions& options() const noexcept;
  /// Retries made and calls given up since the client was made (see RetryPolicy).
  RetryStats retry_stats() const noexcept;

  /// One batch, synchronously. Throws ClientError with the server's code and message.
  ComputeResult compute(const ComputeRequest& req) const;
  /// Same without exceptions: fills `out`, reusing its buffers, and returns the status (on an
  /// error `out` is left invalid).
  RpcStatus compute(const ComputeRequest& req, ComputeResult& out) const;

  /// Starts the call and returns at once; the future's get() returns the result or throws
  /// ClientError.
  std::future<ComputeResult> compute_async(const ComputeRequest& req) const;
  /// Starts the call and returns at once; `done` runs when it completes (see ComputeCallback).
  void compute_async(const ComputeRequest& req, ComputeCallback done) const;

  /// Opens a ComputeStream. Does not wait for the server: an unreachable server shows at the
  /// first step.
  ComputeSession open_session(const SessionOptions& options = {}) const;

  /// The models the server serves. Throws ClientError.
  std::vector<ServedModel> list_models(std::optional<std::chrono::nanoseconds> timeout = {}) const;
  /// One model's joints (names, types, parents, limits) and gravity. Throws ClientError
  /// (NOT_FOUND for an unknown model).
  ModelDescription get_model(const std::string& name, std::optional<std::chrono::nanoseconds> timeout = {}) const;
  /// The scenes the server serves. Throws ClientError.
  std::vector<SceneDescription> list_scenes(std::optional<std::chrono::nanoseconds> timeout = {}) const;
  /// One scene: its joints, what it locks, gravity, force links and outputs. Throws ClientError
  /// (NOT_FOUND for an unknown scene).
  SceneDescription get_scene(const std::string& name, std::optional<std::chrono::nanoseconds> timeout = {}) const;
  /// Registers `scene` with the server while it runs (checked as a configured scene) and returns
  /// it as get_scene does: its joints give the order of its requests' arrays and results. The
  /// same definition again is registered once and answered the same (register after each
  /// reconnection). Throws ClientError: ALREADY_EXISTS (the name is a model's, or a scene's
  /// defined otherwise: the message says what differs), INVALID_ARGUMENT (a bad definition, the
  /// message names the field), NOT_FOUND (an unknown model), RESOURCE_EXHAUSTED (the server's
  /// limits.max_registered_scenes), FAILED_PRECONDITION (no backend can serve it). The server
  /// creates the scene's instances and times them first: allow it a second or more on GPUs.
  SceneDescription register_scene(const SceneDefinition& scene,
                                  std::optional<std::chrono::nanoseconds> timeout = {}) const;
  /// The server's version, backends and limits. Throws ClientError.
  ServerInfo server_info(std::optional<std::chrono::nanoseconds> timeout = {}) const;

  // The same without exceptions.
  RpcStatus list_models(std::vector<ServedModel>& out, std::optional<std::chrono::nanoseconds> timeout = {}) const;
  RpcStatus get_model(const std::string& name, ModelDescription& out,
                      std::optional<std::chrono::nanoseconds> timeout = {}) const;
  RpcStatus list_scenes(std::vector<SceneDescription>& out, std::optional<std::chrono::nanoseconds> timeout = {}) const;
  RpcStatus get_scene(const std::string& name, SceneDescription& out,
                      std::optional<std::chrono::nanoseconds> timeout = {}) const;
  RpcStatus register_scene(const SceneDefinition& scene, SceneDescription& out,
                           std::optional<std::chrono::nanoseconds> timeout = {}) const;
  RpcStatus server_info(ServerInfo& out, std::optional<std::chrono::nanoseconds> timeout = {}) const;

  /// The standard gRPC health check (grpc.health.v1.Health/Check) of `service` ("" = the whole
  /// server), which needs no token: `status` is "SERVING", "NOT_SERVING" (e.g. while the daemon
  /// stops), "SERVICE_UNKNOWN" or "UNKNOWN".
  RpcStatus check_health(std::string& status, const std::string& service = "",
                         std::optional<std::chrono::nanoseconds> timeout = {}) const;

  /// Has the server time its backends again (its scheduler's latency models; seconds, best on an
  /// idle server): `log` gets one line per model measured, `info` the server's state afterwards.
  /// UNAVAILABLE while another calibration runs.
  RpcStatus calibrate(std::vector<std::string>& log, ServerInfo& info,
                      std::optional<std::chrono::nanoseconds> timeout = {}) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace rbdgrad
