// The host side of the plugin ABI (plugins/include/rbdgrad/plugin_api.h): loads backend shared
// libraries, checks their version and function table, and wraps the table in C++ types that
// return Status. Every rbdgrad_error* a plugin returns becomes a Status here and is freed here.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

// One dlopen()ed backend library and its function table; shared by a Plugin and its instances so
// the library is closed only after the last of them is gone. Defined in plugin_loader.cpp.
class LoadedLibrary;

// What a backend says it can do (get_info), copied so it outlives nothing of the plugin's.
struct PluginInfo {
  std::string name;          // the plugin's own name, its kind: "cpu", "cuda", "fpga" (get_info)
  std::string version;       // the plugin's own version, "" when it gives none
  uint32_t precisions = 0;   // rbdgrad_precision flags
  uint32_t outputs = 0;      // rbdgrad_output flags
  uint64_t max_batch = 0;    // largest n per compute call; 0 = no limit
  uint32_t max_nv = 0;       // largest model; 0 = no limit
  uint32_t api_major = 0;    // the plugin API version the plugin was built with (its table)
  uint32_t api_minor = 0;
};

// How an instance runs (describe_instance, plugin API 1.1); empty for older plugins.
struct InstanceDescription {
  std::string mode;    // "" = the backend itself; "csim" = the FPGA kernel's C simulation on the host
  std::string device;  // "NVIDIA H200 (device 0)"; "" = unnamed. The hardware only (it keys calibration)
  std::string detail;  // "kernel compiled for this robot (...)" (API 1.2); "" = nothing more
};

// One model prepared on one backend (create_instance .. destroy_instance). Move-only; a moved-from
// instance may only be destroyed or assigned to (compute then fails with kFailedPrecondition).
// Not thread-safe: the ABI forbids concurrent compute on one instance, so each worker owns its own.
class PluginInstance {
 public:
  PluginInstance(const PluginInstance&) = delete;
  PluginInstance& operator=(const PluginInstance&) = delete;
  PluginInstance(PluginInstance&& other) noexcept;
  PluginInstance& operator=(PluginInstance&& other) noexcept;
  ~PluginInstance();

  /// Computes one batch into the caller's buffers (layout and ownership: plugin_api.h). On a
  /// per-state failure the other states are still computed, batch.state_status (if set) says which
  /// failed, and the Status names the first ("cpu: state 3: ..."). Does not allocate on success.
  Status compute(const rbdgrad_batch& batch);

  /// What the plugin says the instance runs on; empty (and ok) when its table has no
  /// describe_instance.
  Status describe(InstanceDescription& out) const;

  /// The plugin's own prediction of a gradient batch's time (estimate_latency, API 1.2), in us.
  /// Errors: unimplemented when the plugin has no model of its own (the host then measures it),
  /// or the plugin's error; internal for a negative or absurd figure.
  Status estimate_latency(uint32_t precision, uint32_t input_kind, uint64_t n, double& us) const;

 private:
  friend class Plugin;
  PluginInstance(std::shared_ptr<const LoadedLibrary> library, rbdgrad_instance* handle);
  void destroy() noexcept;  // destroy_instance, before the library can be closed

  std::shared_ptr<const LoadedLibrary> library_;
  rbdgrad_instance* handle_ = nullptr;
};

// A loaded backend. Move-only; a moved-from Plugin may only be destroyed or assigned to. Its
// methods are const and may be called from any thread: the ABI says so for create_instance, and
// says nothing for can_run, which we assume is the same.
class Plugin {
 public:
  /// Loads the backend at `path`: dlopen (RTLD_NOW | RTLD_LOCAL), the entry point, the host's API
  /// version against the plugin's, a complete function table, then get_info. Errors name the path:
  /// kNotFound for a missing file, the plugin's own code when get_info fails, kFailedPrecondition
  /// for anything else that makes it unusable. On failure the library is closed again.
  static Status load(const std::string& path, std::unique_ptr<Plugin>& out);

  Plugin(const Plugin&) = delete;
  Plugin& operator=(const Plugin&) = delete;
  Plugin(Plugin&&) noexcept = default;
  Plugin& operator=(Plugin&&) noexcept = default;
  ~Plugin() = default;

  const PluginInfo& info() const noexcept { return info_; }
  const std::string& path() const noexcept { return path_; }
  /// The backend's name: the configured one (PluginConfig::name), else info().name. Unique within
  /// a registry; one library loaded twice (two GPUs) is two Plugins of the same kind.
  const std::string& name() const noexcept { return name_; }

  /// Whether this backend can run n states of `model` in `precision` with `outputs`
  /// (rbdgrad_output flags): ok, or why not (usually kUnimplemented or kUnavailable).
  Status can_run(const rbdgrad_model_desc& model, rbdgrad_precision precision, uint32_t outputs,
                 uint64_t n) const;

  /// Prepares `model` with backend `options` (e.g. {"threads", "4"}; unknown keys are the plugin's
  /// kInvalidArgument). On success `out` holds the instance; it may outlive this Plugin.
  Status create_instance(const rbdgrad_model_desc& model, const std::map<std::string, std::string>& options,
                         std::unique_ptr<PluginInstance>& out) const;

 private:
  Plugin(std::shared_ptr<const LoadedLibrary> library, PluginInfo info, std::string path);
  friend class PluginRegistry;

  std::shared_ptr<const LoadedLibrary> library_;
  PluginInfo info_;
  std::string path_;
  std::string name_;
};

// A plugin that could not be loaded, kept for logs and GetServerInfo.
struct UnavailablePlugin {
  std::string path;
  Status reason;  // never ok; its message names the path
};

// The backends the daemon was configured with. A missing or broken plugin is recorded as
// unavailable, never fatal: the daemon serves with what it has. Not thread-safe while adding;
// after that, lookups are read-only and may run concurrently.
class PluginRegistry {
 public:
  /// Loads each path in order (see add).
  static PluginRegistry load(const std::vector<std::string>& paths);

  /// Loads one plugin under `name` ("" = its own, get_info's): available on success, else
  /// unavailable with the returned reason. A second plugin with a name already taken is
  /// unavailable (kFailedPrecondition, saying to set `name:`).
  Status add(const std::string& path, const std::string& name = "");

  const std::vector<std::unique_ptr<Plugin>>& available() const noexcept { return available_; }
  const std::vector<UnavailablePlugin>& unavailable() const noexcept { return unavailable_; }

  /// The available plugin named `name` ("cpu", "cuda0": Plugin::name), or nullptr.
  const Plugin* find(const std::string& name) const noexcept;

 private:
  std::vector<std::unique_ptr<Plugin>> available_;
  std::vector<UnavailablePlugin> unavailable_;
};

}  // namespace rbdgrad::server
