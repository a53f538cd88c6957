// Loading backends through the C ABI, and the one place where a plugin's rbdgrad_error* becomes a
// Status.
#include "plugin_loader.hpp"

#include <dlfcn.h>

#include <cstddef>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <utility>

namespace rbdgrad::server {

// Owns the dlopen() handle: closed when the Plugin and all its instances are gone, since the
// function table, the info strings and the instances' code all live in the library.
class LoadedLibrary {
 public:
  explicit LoadedLibrary(void* handle) : handle_(handle) {}
  LoadedLibrary(const LoadedLibrary&) = delete;
  LoadedLibrary& operator=(const LoadedLibrary&) = delete;
  ~LoadedLibrary() { dlclose(handle_); }

  void* handle() const noexcept { return handle_; }

  const rbdgrad_plugin_api* api = nullptr;  // set once the table has been checked
  // the table's describe_instance when the plugin is of minor >= 1 and has one, else null
  rbdgrad_error* (*describe_instance)(const rbdgrad_instance*, rbdgrad_instance_info*) = nullptr;
  // the table's estimate_latency when the plugin is of minor >= 2 and has one, else null
  rbdgrad_error* (*estimate_latency)(const rbdgrad_instance*, uint32_t, uint32_t, uint64_t, double*) = nullptr;
  std::string name;                         // the plugin's name: the prefix of its errors

 private:
  void* handle_;
};

namespace {

// The function table as API 1.0 defined it. Minors only append, so a table from any 1.x plugin is
// at least this long; a longer one is from a newer minor and we read only what we know.
constexpr size_t kTableSizeV1_0 =
    offsetof(rbdgrad_plugin_api, error_delete) + sizeof(rbdgrad_plugin_api::error_delete);

// API 1.1 appended describe_instance, 1.2 estimate_latency.
constexpr size_t kTableSizeV1_1 =
    offsetof(rbdgrad_plugin_api, describe_instance) + sizeof(rbdgrad_plugin_api::describe_instance);
constexpr size_t kTableSizeV1_2 =
    offsetof(rbdgrad_plugin_api, estimate_latency) + sizeof(rbdgrad_plugin_api::estimate_latency);

std::string api_version(uint32_t major, uint32_t minor) {
  return std::to_string(major) + "." + std::to_string(minor);
}

const std::string& host_api_version() {
  static const std::string version = api_version(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  return version;
}

Status status_for(uint32_t code, std::string message) {
  switch (code) {
    case RBDGRAD_ERROR_INVALID_ARGUMENT: return invalid_argument(std::move(message));
    case RBDGRAD_ERROR_UNSUPPORTED: return unimplemented(std::move(message));
    case RBDGRAD_ERROR_NUMERICAL: return out_of_range(std::move(message));
    case RBDGRAD_ERROR_UNAVAILABLE: return unavailable(std::move(message));
    case RBDGRAD_ERROR_INTERNAL: return {StatusCode::kInternal, std::move(message)};
    case RBDGRAD_ERROR_OUT_OF_RANGE: return out_of_range(std::move(message));
  }
  // a code this host does not know is a plugin bug; keep the number for whoever reads the log
  return {StatusCode::kInternal, std::move(message) + " (unknown plugin error code " +
                                     std::to_string(code) + ")"};
}

// Converts a plugin's error to a Status prefixed with `prefix` and frees it with the plugin's own
// error_delete (null = ok). Every call into the table that returns an error goes through here.
Status take_error(const rbdgrad_plugin_api& api, std::string_view prefix, rbdgrad_error* error) {
  if (error == nullptr) return Status::ok();
  // freed on every path, even if building the message throws
  auto free_error = [&api](rbdgrad_error* e) { api.error_delete(e); };
  const std::unique_ptr<rbdgrad_error, decltype(free_error)> owned(error, free_error);
  const char* message = api.error_message(error);
  std::string text(prefix);
  text += ": ";
  text += message != nullptr ? message : "(no message)";
  return status_for(api.error_code(error), std::move(text));
}

// Every entry of a v1.0 table must be set: the host never checks for null on the request path.
Status check_table(const rbdgrad_plugin_api& api, const std::string& where) {
  const std::pair<const char*, bool> entries[] = {
      {"get_info", api.get_info == nullptr},
      {"can_run", api.can_run == nullptr},
      {"create_instance", api.create_instance == nullptr},
      {"compute", api.compute == nullptr},
      {"destroy_instance", api.destroy_instance == nullptr},
      {"error_code", api.error_code == nullptr},
      {"error_message", api.error_message == nullptr},
      {"error_delete", api.error_delete == nullptr},
  };
  for (const auto& [name, missing] : entries) {
    if (missing) return failed_precondition(where + ": function table entry '" + name + "' is NULL");
  }
  return Status::ok();
}

}  // namespace

// --- Plugin ---

Plugin::Plugin(std::shared_ptr<const LoadedLibrary> library, PluginInfo info, std::string path)
    : library_(std::move(library)), info_(std::move(info)), path_(std::move(path)), name_(info_.name) {}

Status Plugin::load(const std::string& path, std::unique_ptr<Plugin>& out) {
  const std::string where = "plugin " + path;

  // RTLD_NOW: a missing dependency fails here, not in the middle of a request;
  // RTLD_LOCAL: backends cannot see (or clash with) each other's symbols
  dlerror();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    std::string message = where + ": cannot load: " + (why != nullptr ? why : "unknown dlopen error");
    std::error_code ec;
    const bool missing = !std::filesystem::exists(path, ec) && !ec;
    return missing ? not_found(std::move(message)) : failed_precondition(std::move(message));
  }
  // from here every early return closes the library again
  auto library = std::make_shared<LoadedLibrary>(handle);

  void* symbol = dlsym(handle, RBDGRAD_PLUGIN_ENTRY_SYMBOL);
  if (symbol == nullptr) return failed_precondition(where + " does not export " RBDGRAD_PLUGIN_ENTRY_SYMBOL);
  const auto entry = reinterpret_cast<rbdgrad_plugin_entry_fn>(symbol);

  // version handshake: the plugin refuses us (NULL), or we refuse its table
  const rbdgrad_plugin_api* api = entry(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  if (api == nullptr) {
    return failed_precondition(where + " refused host plugin API " + host_api_version() +
                               " (it needs another version)");
  }
  if (api->api_major != RBDGRAD_PLUGIN_API_MAJOR) {
    return failed_precondition(where + " is built for plugin API " + api_version(api->api_major, api->api_minor) +
                               ", host plugin API is " + host_api_version() + " (the majors must match)");
  }
  if (api->struct_size < kTableSizeV1_0) {
    return failed_precondition(where + ": function table is " + std::to_string(api->struct_size) +
                               " bytes, plugin API " + api_version(api->api_major, api->api_minor) +
                               " needs at least " + std::to_string(kTableSizeV1_0) + " (host " +
                               host_api_version() + ")");
  }
  if (Status status = check_table(*api, where); !status) return status;
  library->api = api;
  if (api->struct_size >= kTableSizeV1_1) library->describe_instance = api->describe_instance;
  if (api->struct_size >= kTableSizeV1_2) library->estimate_latency = api->estimate_latency;

  // what the backend can do, copied: its strings live only as long as the library
  rbdgrad_plugin_info raw{};
  raw.struct_size = sizeof(raw);
  if (Status status = take_error(*api, where + ": get_info", api->get_info(&raw)); !status) return status;
  if (raw.name == nullptr || raw.name[0] == '\0') return failed_precondition(where + ": get_info gave no name");
  PluginInfo info;
  info.name = raw.name;
  info.version = raw.version != nullptr ? raw.version : "";
  info.precisions = raw.precisions;
  info.outputs = raw.outputs;
  info.max_batch = raw.max_batch;
  info.max_nv = raw.max_nv;
  info.api_major = api->api_major;
  info.api_minor = api->api_minor;
  library->name = info.name;

  out.reset(new Plugin(std::move(library), std::move(info), path));
  return Status::ok();
}

Status Plugin::can_run(const rbdgrad_model_desc& model, rbdgrad_precision precision, uint32_t outputs,
                       uint64_t n) const {
  const rbdgrad_plugin_api& api = *library_->api;
  return take_error(api, library_->name, api.can_run(&model, static_cast<uint32_t>(precision), outputs, n));
}

Status Plugin::create_instance(const rbdgrad_model_desc& model, const std::map<std::string, std::string>& options,
                               std::unique_ptr<PluginInstance>& out) const {
  // the ABI takes parallel C string arrays, borrowed for the duration of the call
  std::vector<const char*> keys, values;
  keys.reserve(options.size());
  values.reserve(options.size());
  for (const auto& [key, value] : options) {
    keys.push_back(key.c_str());
    values.push_back(value.c_str());
  }
  const rbdgrad_options raw{sizeof(rbdgrad_options), options.size(), keys.data(), values.data()};

  const rbdgrad_plugin_api& api = *library_->api;
  rbdgrad_instance* handle = nullptr;
  if (Status status = take_error(api, library_->name, api.create_instance(&model, &raw, &handle)); !status) {
    return status;
  }
  if (handle == nullptr) return {StatusCode::kInternal, library_->name + ": create_instance returned no instance"};
  out.reset(new PluginInstance(library_, handle));
  return Status::ok();
}

// --- PluginInstance ---

PluginInstance::PluginInstance(std::shared_ptr<const LoadedLibrary> library, rbdgrad_instance* handle)
    : library_(std::move(library)), handle_(handle) {}

PluginInstance::PluginInstance(PluginInstance&& other) noexcept
    : library_(std::move(other.library_)), handle_(std::exchange(other.handle_, nullptr)) {}

PluginInstance& PluginInstance::operator=(PluginInstance&& other) noexcept {
  if (this != &other) {
    // our instance goes before our reference to its library does
    destroy();
    library_ = std::move(other.library_);
    handle_ = std::exchange(other.handle_, nullptr);
  }
  return *this;
}

PluginInstance::~PluginInstance() { destroy(); }

void PluginInstance::destroy() noexcept {
  if (handle_ != nullptr) library_->api->destroy_instance(std::exchange(handle_, nullptr));
}

Status PluginInstance::describe(InstanceDescription& out) const {
  out = {};
  if (handle_ == nullptr) return failed_precondition("describe on a moved-from plugin instance");
  if (library_->describe_instance == nullptr) return Status::ok();
  rbdgrad_instance_info raw{};
  raw.struct_size = sizeof(raw);
  if (Status s = take_error(*library_->api, library_->name + ": describe_instance",
                            library_->describe_instance(handle_, &raw));
      !s)
    return s;
  out.mode = raw.mode != nullptr ? raw.mode : "";
  out.device = raw.device != nullptr ? raw.device : "";
  out.detail = raw.detail != nullptr ? raw.detail : "";  // a 1.1 plugin leaves it null
  return Status::ok();
}

Status PluginInstance::estimate_latency(uint32_t precision, uint32_t input_kind, uint64_t n, double& us) const {
  if (handle_ == nullptr) return failed_precondition("estimate_latency on a moved-from plugin instance");
  if (library_->estimate_latency == nullptr) return unimplemented(library_->name + " has no latency model of its own");
  double value = 0;
  if (Status s = take_error(*library_->api, library_->name + ": estimate_latency",
                            library_->estimate_latency(handle_, precision, input_kind, n, &value));
      !s)
    return s;
  if (!(value >= 0) || value > 1e12)
    return Status(StatusCode::kInternal, library_->name + ": estimate_latency gave " + std::to_string(value) + " us");
  us = value;
  return Status::ok();
}

Status PluginInstance::compute(const rbdgrad_batch& batch) {
  if (handle_ == nullptr) return failed_precondition("compute on a moved-from plugin instance");
  const rbdgrad_plugin_api& api = *library_->api;
  return take_error(api, library_->name, api.compute(handle_, &batch));
}

// --- PluginRegistry ---

PluginRegistry PluginRegistry::load(const std::vector<std::string>& paths) {
  PluginRegistry registry;
  // each outcome is recorded in the registry; the caller reads it from there
  for (const std::string& path : paths) static_cast<void>(registry.add(path));
  return registry;
}

Status PluginRegistry::add(const std::string& path, const std::string& name) {
  std::unique_ptr<Plugin> plugin;
  Status status = Plugin::load(path, plugin);
  if (status) {
    if (!name.empty()) plugin->name_ = name;
    // logs, metrics and routing name their backend, so a name must mean one backend
    if (const Plugin* taken = find(plugin->name())) {
      status = failed_precondition("plugin " + path + ": name '" + plugin->name() + "' is already taken by " +
                                   taken->path() + (taken->path() == path ? " (the same library)" : "") +
                                   ": give each plugins entry of it its own `name:` (e.g. " + plugin->info().name +
                                   "0, " + plugin->info().name + "1)");
    }
  }
  if (!status) {
    unavailable_.push_back({path, status});
    return status;
  }
  available_.push_back(std::move(plugin));
  return Status::ok();
}

const Plugin* PluginRegistry::find(const std::string& name) const noexcept {
  for (const auto& plugin : available_) {
    if (plugin->name() == name) return plugin.get();
  }
  return nullptr;
}

}  // namespace rbdgrad::server
