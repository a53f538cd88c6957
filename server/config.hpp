// The daemon's configuration: built-in defaults, overridden by a YAML file
// (configs/default.yaml is the reference), then by command-line flags.
// Parsing reports errors as Status values naming the key path and line; nothing throws.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

// Where the daemon accepts connections. At least one should be set; the daemon checks that.
struct ListenConfig {
  // TCP address as "host:port". Default "127.0.0.1:50051" (loopback only). Empty = no TCP.
  std::string tcp = "127.0.0.1:50051";
  // Unix domain socket path. Default "/tmp/rbdgradd.sock". Empty = no Unix socket.
  std::string unix_socket = "/tmp/rbdgradd.sock";
  // A TCP address that is not loopback (127.0.0.0/8, ::1, localhost) without TLS is refused at
  // start-up (check_security) unless this is true. Default false.
  bool insecure = false;

  bool operator==(const ListenConfig&) const = default;
};

// TLS on the TCP listener (the Unix socket stays plaintext: file permissions guard it). The files
// are read at start-up; each error names the file.
struct TlsConfig {
  // PEM server certificate chain and its private key: both set = TLS, both empty = plaintext.
  std::string cert_file;
  std::string key_file;
  // PEM CA certificate(s): set = mutual TLS, every client must present a certificate signed by one
  // of them. Needs cert_file and key_file. Default "" = clients are not asked for a certificate.
  std::string client_ca_file;

  bool enabled() const noexcept { return !cert_file.empty() && !key_file.empty(); }
  bool operator==(const TlsConfig&) const = default;
};

// Token authentication.
struct AuthConfig {
  // A file of "NAME TOKEN" lines ('#' starts a comment line), read at start-up. Set = every call
  // but the gRPC health service needs the metadata "authorization: Bearer TOKEN" (else
  // UNAUTHENTICATED); the NAME stands for the client in logs and per-client limits. Default "" =
  // no authentication.
  std::string tokens_file;

  bool operator==(const AuthConfig&) const = default;
};

// One robot model served by the daemon. Exactly one of `urdf` / `embedded` is non-empty.
struct ModelConfig {
  // Name clients use to address the model. Required, unique. No default.
  std::string name;
  // Path of a URDF file. Default empty (use `embedded`).
  std::string urdf;
  // Name of a robot compiled into the daemon ("iiwa14", "panda", ...). Default empty.
  // The daemon checks the name against the embedded robots when it loads models.
  std::string embedded;
  // Gravity [gx, gy, gz] in m/s^2. Default unset = the model's own (0, 0, -9.81).
  std::optional<std::array<double, 3>> gravity;
  // Joints held at fixed values (rad or m), in the file's order: the model is reduced to the
  // other joints (lock_joints: each locked body folded into the one it hangs from), so every
  // backend works on the smaller tree, and requests, results and GetModel use the kept joints
  // in their order. Default none.
  std::vector<std::pair<std::string, double>> locked_joints{};  // {}: a list that stops before it leaves it empty

  bool operator==(const ModelConfig&) const = default;
};

// A scene (issue 8): a configured model reduced for one fixed problem and served as a model of its
// own; requests name it with ComputeRequest.scene. Registered at start-up (server/scene.hpp), or
// later through RegisterScene (server/scene_registrar.hpp).
struct SceneConfig {
  // Name requests use. Required, unique among scenes and models. No default.
  std::string name;
  // The configured model (ModelConfig::name) it is made from. Required. No default.
  std::string model;
  // Joints held at fixed values (rad or m), on top of the model's own; as ModelConfig. Default none.
  std::vector<std::pair<std::string, double>> locked_joints;
  // false: computed without gravity. Default true (the model's gravity).
  bool gravity = true;
  // The links that receive external forces, in the order of a request's fext; the others skip
  // that term. Each must be the child link of one of the scene's joints. Default none.
  std::vector<std::string> force_links;
  // What the scene computes, by the names of GetScene's outputs: qdd, minv, dqdd_dq, dqdd_dqd,
  // tau, dtau_dq, dtau_dqd, m. Default [dqdd_dq, dqdd_dqd].
  std::vector<std::string> outputs = {"dqdd_dq", "dqdd_dqd"};
  // "computed" (default): M^-1 is computed; "supplied": every request brings it (minv).
  std::string minv = "computed";
  bool operator==(const SceneConfig&) const = default;
};

// A backend plugin to dlopen(). The CPU backend needs no entry: the daemon looks it up next to its
// own binary (<prefix>/lib/rbdgrad/librbdgrad_cpu.so installed, build/plugins/cpu in the build
// tree) unless this list yields a plugin of kind "cpu". A plugin that fails to load is logged and
// skipped, under a name taken from its file name (librbdgrad_cuda.so -> "cuda").
struct PluginConfig {
  // Path of the shared object. Required. No default.
  std::string path;
  // Options handed to the plugin at initialisation, uninterpreted here. Default empty.
  std::map<std::string, std::string> options;
  // Instances of this backend per served model: how many requests for one model it runs at once
  // (a CUDA instance has its own streams and buffers, so requests on different instances overlap
  // on the GPU). Range [1, 64]; 0 (not set) = 1.
  std::int64_t instances = 0;
  // The backend's name in routing, logs, metrics and server info: [a-z0-9_-]{1,32}, unique among
  // the loaded backends (last here, so that {path, options, instances} still initialises the rest). Default "" = the plugin's own name (get_info: "cuda"). Set it to load one
  // library more than once, e.g. cuda0 and cuda1 with options {device: "0"} and {device: "1"}: each
  // is a backend of its own (instances, latency models, queue), and a request's backend hint names
  // the kind (the plugin's own name), so BACKEND_CUDA may go to either.
  std::string name{};

  bool operator==(const PluginConfig&) const = default;
};

// Admission limits: requests beyond them are rejected instead of queued without bound.
struct LimitsConfig {
  // Most states (batch columns) one request may carry. Default 65536. Range [1, 2^31-1].
  int64_t max_states_per_request = 65536;
  // Largest gRPC message accepted or sent, in bytes. Default 0 = derived at start-up from
  // max_states_per_request and the largest model served (the largest request and response any
  // allowed request makes, plus a margin; see server/message_size.hpp). Range [0, 2^31-1].
  int64_t max_message_bytes = 0;
  // Compute requests in flight at once (unary and streamed); more are rejected
  // RESOURCE_EXHAUSTED. Default 256. Range [1, 2^31-1].
  int64_t max_concurrent_requests = 256;
  // Dynamic batching: how long a small request may wait for others to share its backend call,
  // in microseconds (server/coalescer.hpp). Default 0 = no batching. Range [0, 10^7].
  int64_t max_queue_delay_us = 0;
  // Per client (the token's NAME with auth, else the peer's address without the port): requests
  // per second, the refill rate of a token bucket that every Dynamics call and every stream
  // message takes one token from. Default 0 = unlimited. Range [0, 10^9].
  double client_requests_per_second = 0;
  // The bucket's size (the burst a client may send at once). Default 0 = max(1, rate).
  // Range [0, 2^31-1].
  int64_t client_burst = 0;
  // Compute requests in flight per client (unary and streamed). Default 0 = unlimited.
  // Range [0, 2^31-1].
  int64_t client_max_concurrent = 0;
  // Scenes registered at run time (RegisterScene) on top of the configured ones; more are
  // rejected RESOURCE_EXHAUSTED. Each costs its instances on every backend and its place is kept
  // from start-up. Default 64. Range [0, 4096]; 0 = no registration.
  int64_t max_registered_scenes = 64;

  bool operator==(const LimitsConfig&) const = default;
};

// How requests without a backend hint are routed (server/scheduler.hpp), and the latency models
// the routing uses.
struct SchedulerConfig {
  // "cost" (default): the backend predicted to finish first (its queue's wait plus its latency
  // model at N); "threshold": N <= small_n to the fpga, N >= large_n to cuda, else the cpu.
  std::string policy = "cost";
  // The threshold policy's limits; -1 (default) = where the latency models cross. Range [-1, 2^31-1].
  int64_t small_n = -1;
  int64_t large_n = -1;
  // "start" (default): at start-up, time every backend on every model and precision that the
  // calibration file does not hold (a backend's own model, the FPGA's cycle count, is taken as
  // given); "off": only the file and the backends' own models. Without any model the cpu (else the
  // first backend that serves the model) takes every request, as with no scheduler.
  std::string calibrate = "start";
  // Where the measured models are kept across restarts; an entry is reused while the backend's
  // hardware, plugin, options and the model are unchanged. Default "" = not kept.
  std::string calibration_file;
  // Batch sizes timed, ascending, each in [1, 2^31-1]. Default 1, 4, 16, 64, 256, 1024.
  std::vector<int64_t> calibration_sizes = {1, 4, 16, 64, 256, 1024};
  // Dynamic batching (limits.max_queue_delay_us > 0): requests of fewer states wait for others,
  // and a group of at least this many goes at once. Default 256. Range [1, 2^31-1].
  int64_t preferred_batch_states = 256;
  // The cost policy splits a request of at least this many states across backends (e.g. GPU and
  // CPU) when their latency models and queues predict it finishes at least 10% sooner than on
  // the best backend alone. 0 = never split. Default 4096. Range [0, 2^31-1].
  int64_t split_min_states = 4096;
  // A backend call (a request computed alone: not a split share or a dynamic batch) that has run
  // this long is given up: the request runs again on the next best backend that serves its model
  // and precision (the hung call's result, when it comes, is dropped), and the backend is suspect:
  // routing avoids it until a call on it succeeds again. Milliseconds; -1 (default) = from the
  // latency model, max(1 s, 20x the call's prediction); 0 = never. Range [-1, 2^31-1].
  int64_t backend_timeout_ms = -1;

  bool operator==(const SchedulerConfig&) const = default;
};

enum class LogLevel { kTrace, kDebug, kInfo, kWarn, kError };

// "trace", "debug", "info", "warn", "error".
const char* log_level_name(LogLevel level) noexcept;
// Fills `out` from one of the names above; false for anything else.
bool parse_log_level(const std::string& name, LogLevel& out);

struct ServerConfig {
  // Addresses to listen on. Default: TCP 127.0.0.1:50051 and /tmp/rbdgradd.sock.
  ListenConfig listen;
  // TLS on the TCP listener. Default off.
  TlsConfig tls;
  // Token authentication. Default off.
  AuthConfig auth;
  // Models to load at start-up. Default: one model "iiwa14" from the embedded iiwa14.
  std::vector<ModelConfig> models = {ModelConfig{"iiwa14", "", "iiwa14", std::nullopt, {}}};
  // Scenes made from those models (SceneConfig). Default none.
  std::vector<SceneConfig> scenes;
  // Extra backend plugins. Default empty (the CPU backend is always found next to the binary).
  std::vector<PluginConfig> plugins;
  // Threads of the CPU backend's instance (its "threads" option, unless the CPU plugin's own
  // options set it): one batch is split over them. Default 0 = std::thread::hardware_concurrency().
  // Range [0, 4096].
  int64_t workers = 0;
  // Requests of at most this many states run on the gRPC thread that received them when their
  // backend instance is free and nothing waits for it; larger ones are handed to the instance's
  // thread. Saves a thread hand-off (tens of us) per small request; a gRPC thread is then busy for
  // the computation. Default 128. Range [0, 2^31-1]; 0 = always hand over. Under
  // scheduler.backend_timeout_ms, only the CPU backend's calls run inline.
  int64_t inline_max_states = 128;
  // The backend that computes again, in its best floating-point precision, the states of a
  // PRECISION_FIXED request that left the Q16.16 range (the response lists them). Default "cpu";
  // "" = none: such a state then fails the request, naming it.
  std::string fixed_point_fallback = "cpu";
  // Admission limits (see LimitsConfig).
  LimitsConfig limits;
  // Routing and calibration (see SchedulerConfig).
  SchedulerConfig scheduler;
  // Where the Prometheus metrics are served over HTTP (/metrics), "host:port". Default "" = not
  // served (they are still counted).
  std::string metrics_listen;
  // Least severe log level written. Default info.
  LogLevel log_level = LogLevel::kInfo;

  bool operator==(const ServerConfig&) const = default;
};

// true for a backend name a plugin entry may set: 1 to 32 of [a-z0-9_-].
bool valid_backend_name(const std::string& name) noexcept;

// Reads the YAML file at `path` and applies it on top of `out`'s current values
// (pass a default-constructed ServerConfig to start from the defaults).
// not_found if the file cannot be read; invalid_argument naming key and line otherwise.
Status load_config_file(const std::string& path, ServerConfig& out);

// As load_config_file, from text; `name_for_messages` prefixes every error ("rbdgradd.yaml").
// Unknown keys, wrong types and out-of-range values are errors; `out` is unspecified on error.
Status parse_config(const std::string& yaml_text, const std::string& name_for_messages,
                    ServerConfig& out);

// Applies command-line flags on top of `cfg` (flags win over the file):
// --listen <host:port>, --unix-socket <path>, --workers <n>, --log-level <lvl>, --max-states <n>.
// Both "--flag value" and "--flag=value" are accepted. Unknown flags are invalid_argument.
Status apply_flag_overrides(const std::vector<std::string>& args, ServerConfig& cfg);

// true when `tcp` ("host:port", "[v6]:port") names a loopback host: 127.0.0.0/8, ::1 or localhost.
bool is_loopback_address(const std::string& tcp);

// The rules that need the whole configuration (flags applied), checked at start-up: tls.cert_file
// and tls.key_file go together, tls.client_ca_file needs them, and a listen.tcp that is not
// loopback needs TLS or listen.insecure: true. invalid_argument saying which rule and how to fix it.
Status check_security(const ServerConfig& cfg);

// Multi-line human summary for the start-up log.
std::string describe(const ServerConfig& cfg);

}  // namespace rbdgrad::server
