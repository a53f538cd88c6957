// The daemon's backends: the plugins it loaded (the CPU backend found next to the binary, the
// others from the configuration), an InstancePool per (model, backend), and the routing of a
// request to one of them. A plugin that is missing or broken, or that cannot take a model, is
// recorded as unavailable with the reason and skipped; the daemon decides whether it can serve
// with what is left.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "config.hpp"
#include "instance_pool.hpp"
#include "model_registry.hpp"
#include "plugin_loader.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

// The outcome of loading one backend, for the start-up log and GetServerInfo.
struct BackendState {
  std::string name;   // the backend's name: its plugins entry's `name`, else the plugin's own
                      // ("cpu", "cuda"); for one that did not load and has no configured name,
                      // derived from its file name (librbdgrad_cuda.so -> "cuda", backend_name_from_path)
  std::string kind;   // the plugin's own name (get_info), what hints and the API's enum mean:
                      // "cuda" for backends cuda0 and cuda1; from the file name when it did not load
  std::string path;   // the shared object
  bool ready = false;  // loaded, and serves at least one model
  std::string reason;  // why not ready; "" when ready
  PluginInfo info;     // what the plugin says it can do; meaningful when it loaded
  // "model 'hyq': <why>" for each model this backend cannot serve (it serves the others); a scene
  // registered later (add_model) is appended, by the one registering thread: read it at start-up
  // or after the registration, not during one
  std::vector<std::string> model_problems;
  std::size_t instances_per_model = 0;  // instances created per served model
  std::string options;  // "threads=8": the instance options it was given, for the log
  // how its instances run (the first instance's describe_instance): mode "csim" when the FPGA
  // backend runs its kernel's C simulation on the host; device for the log
  InstanceDescription description;
};

// Where one request goes.
struct Route {
  InstancePool* pool = nullptr;    // the (model, backend) pool that runs it
  const Plugin* plugin = nullptr;  // for can_run
  const BackendState* backend = nullptr;
  rbdgrad_precision precision = RBDGRAD_PRECISION_F64;  // resolved: never "auto"
};

/// The precisions from the most accurate: a backend's best is the first it has.
inline constexpr std::uint32_t kPrecisionOrder[] = {RBDGRAD_PRECISION_F64, RBDGRAD_PRECISION_F32,
                                                    RBDGRAD_PRECISION_FIXED_Q16_16};

/// "f64", "f32", "fixed", or "unknown": the precision names of messages and logs.
const char* precision_label(std::uint32_t precision) noexcept;
/// The precisions of `flags` in the order f64, f32, fixed: "f64, f32".
std::string precision_list(std::uint32_t flags);
/// librbdgrad_cuda.so -> "cuda", /x/fake_fpga.so -> "fake_fpga": the name a backend that failed to
/// load is reported under (the file name without directory, "lib" and "rbdgrad_" prefixes and
/// everything from the first '.').
std::string backend_name_from_path(const std::string& path);

class BackendPool {
 public:
  struct Options {
    // The built-in CPU backend (librbdgrad_cpu.so); loaded unless `plugins` already yields a
    // plugin named "cpu". Empty = none.
    std::string cpu_plugin_path;
    // Further built-in backends (the CUDA and FPGA plugins next to the binary), loaded after the
    // CPU one when their file exists and no configured plugin has their name. A missing file is
    // not an error: a build without CUDA has no CUDA plugin.
    std::vector<std::string> optional_plugin_paths;
    // Extra backends, loaded in order before the CPU one.
    std::vector<PluginConfig> plugins;
    // Threads of each CPU instance (the plugin's "threads" option) unless the CPU plugin's own
    // options set "threads". 0 = std::thread::hardware_concurrency().
    std::int64_t workers = 0;
    // Instances per (model, backend): how many requests for one model run at once on a backend,
    // unless its plugin entry sets `instances`. Default 1: a CPU instance already spreads one
    // batch over `workers` threads.
    std::size_t instances_per_model = 1;
    InstancePool::Options pool;
  };

  /// Loads the plugins and creates the instances of every model on each. Never fails as a whole:
  /// every problem is recorded in backends(); ready_count() says whether anything can serve.
  /// The per-model tables are sized for models.capacity(): scenes registered later (add_model).
  static std::unique_ptr<BackendPool> create(const Options& options, const ModelRegistry& models);

  /// A scene registered while requests are served: each ready backend creates its instances of
  /// `model` as at start-up (the same options, the model's plan through create_instance) before
  /// `model` is published in the registry, so no request can reach them half made. A backend that
  /// cannot serve it gets the reason in model_problems, as at start-up (unless no backend serves
  /// it: then it is not registered). Returns those problems ("backend cuda: <why>"), empty when
  /// every ready backend serves it. One caller at a time.
  std::vector<std::string> add_model(const ServedModel& model);
  /// Whether any backend has instances of `model`.
  bool serves(const ServedModel& model) const noexcept;
  /// What `model`'s instances say of how they run (InstanceDescription::detail, e.g. the CUDA
  /// kernel compiled for a scene with its stages fixed), one line per backend where it differs
  /// from what the backend's first instance said (BackendState::description, in the start-up
  /// line): "backend cuda: <detail>". Any thread.
  std::vector<std::string> model_details(const ServedModel& model) const;

  ~BackendPool();
  BackendPool(const BackendPool&) = delete;
  BackendPool& operator=(const BackendPool&) = delete;

  /// Every backend tried, in load order; a backend that was never configured is not listed.
  const std::vector<BackendState>& backends() const noexcept { return states_; }
  /// How many backends are ready.
  std::size_t ready_count() const noexcept;

  /// Picks the backend and precision for a request on `model`.
  /// \param backend a backend's name ("cuda0"), else a kind ("cuda": the first backend of that
  ///        kind that serves the model), or "" for automatic: the cpu when it serves the model,
  ///        else the first ready backend that does.
  /// \param precision one rbdgrad_precision flag, or 0 for automatic: f64 when the backend has it,
  ///        else f32, else fixed.
  /// Errors: unavailable "backend cuda is not available: <why, or 'not configured'>" (also
  /// "... for model 'x': <why>"); invalid_argument "backend cuda does not support precision fixed
  /// (it supports f64, f32)".
  Status route(const ServedModel& model, std::string_view backend, std::uint32_t precision, Route& out) const;

  /// The names of the loaded backends that `name` stands for: the backend of that name, else
  /// every backend of that kind ("cuda" -> cuda0, cuda1), in load order; empty when none.
  std::vector<std::string> resolve(std::string_view name) const;

  /// The pool of the backend named `backend` for `model`, or null when it does not serve it (or
  /// is not loaded). For the scheduler: its load, its instances' own models, calibration.
  InstancePool* pool(std::string_view backend, const ServedModel& model) const;
  /// The loaded plugin named `backend`, or null.
  const Plugin* plugin(std::string_view backend) const;

 private:
  // one loaded plugin with its pools, indexed by model; parallel to states_ where loaded
  struct Backend {
    std::size_t state = 0;  // index in states_
    const Plugin* plugin = nullptr;
    // (models.capacity()) nullptr where the model failed or is not registered yet; an entry is
    // written once, before its model is published (ModelRegistry::append), never reallocated
    std::vector<std::unique_ptr<InstancePool>> pools;
    std::vector<std::string> model_reason;  // (models.capacity()) why, where pools[i] is null
    std::map<std::string, std::string> instance_options;  // what every instance was created with
  };

  BackendPool() = default;
  // instances_per_model: the plugin entry's `instances`, else Options::instances_per_model
  void add_backend(const Plugin& plugin, const std::map<std::string, std::string>& configured_options,
                   const Options& options, const ModelRegistry& models, std::size_t instances_per_model);
  // the instances of `model` on `backend` (state.instances_per_model of them): "" and `out` set, or
  // why not
  std::string make_instances(const Backend& backend, const BackendState& state, const ServedModel& model,
                             std::vector<std::unique_ptr<PluginInstance>>& out) const;
  const Backend* find(std::string_view name) const noexcept;
  // the backend named `name`, else the first of kind `name` that serves `model`, else the first of
  // that kind; null when none
  const Backend* find_for(std::string_view name, const ServedModel& model) const noexcept;
  bool has_kind(std::string_view kind) const noexcept;
  Status unavailable_backend(std::string_view name) const;

  InstancePool::Options pool_options_;
  PluginRegistry registry_;        // owns the loaded plugins
  std::vector<BackendState> states_;
  std::vector<Backend> backends_;  // the loaded ones
};

}  // namespace rbdgrad::server
