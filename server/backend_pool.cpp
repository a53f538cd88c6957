// Loading the backends, creating their instances per model, and routing requests to them.
#include "backend_pool.hpp"

#include <algorithm>
#include <filesystem>
#include <thread>
#include <utility>

namespace rbdgrad::server {
namespace {

std::int64_t cpu_threads(std::int64_t workers) {
  if (workers > 0) return workers;
  const unsigned hw = std::thread::hardware_concurrency();  // 0 when unknown
  return hw > 0 ? hw : 1;
}

std::string options_text(const std::map<std::string, std::string>& options) {
  std::string out;
  for (const auto& [key, value] : options) {
    if (!out.empty()) out += ", ";
    out += key + "=" + value;
  }
  return out;
}

}  // namespace

const char* precision_label(std::uint32_t precision) noexcept {
  switch (precision) {
    case RBDGRAD_PRECISION_F64: return "f64";
    case RBDGRAD_PRECISION_F32: return "f32";
    case RBDGRAD_PRECISION_FIXED_Q16_16: return "fixed";
    default: return "unknown";
  }
}

std::string precision_list(std::uint32_t flags) {
  std::string out;
  for (std::uint32_t p : kPrecisionOrder) {
    if ((flags & p) == 0) continue;
    if (!out.empty()) out += ", ";
    out += precision_label(p);
  }
  return out.empty() ? "none" : out;
}

std::string backend_name_from_path(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  name = name.substr(0, name.find('.'));
  for (std::string_view prefix : {"lib", "rbdgrad_"}) {
    if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0) name.erase(0, prefix.size());
  }
  return name.empty() ? path : name;
}

BackendPool::~BackendPool() = default;

std::unique_ptr<BackendPool> BackendPool::create(const Options& options, const ModelRegistry& models) {
  std::unique_ptr<BackendPool> pool(new BackendPool());
  pool->pool_options_ = options.pool;
  const auto load = [&](const std::string& path, const std::string& name,
                        const std::map<std::string, std::string>& plugin_options, std::int64_t instances) {
    if (Status s = pool->registry_.add(path, name); !s) {
      BackendState state;
      state.kind = backend_name_from_path(path);
      state.name = name.empty() ? state.kind : name;
      state.path = path;
      state.reason = s.message();
      pool->states_.push_back(std::move(state));
      return;
    }
    const std::size_t per_model = instances > 0 ? static_cast<std::size_t>(instances) : options.instances_per_model;
    pool->add_backend(*pool->registry_.available().back(), plugin_options, options, models, per_model);
  };
  for (const PluginConfig& plugin : options.plugins) load(plugin.path, plugin.name, plugin.options, plugin.instances);
  // the built-in CPU backend, unless the configuration brought its own (under any name)
  if (!options.cpu_plugin_path.empty() && !pool->has_kind("cpu")) load(options.cpu_plugin_path, "", {}, 0);
  for (const std::string& path : options.optional_plugin_paths) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) continue;
    // a configured plugin of that kind (or name), loaded or not, is the one the operator asked for
    const std::string name = backend_name_from_path(path);
    const auto& states = pool->states_;
    if (std::any_of(states.begin(), states.end(),
                    [&](const BackendState& s) { return s.name == name || s.kind == name; }))
      continue;
    load(path, "", {}, 0);
  }
  return pool;
}

void BackendPool::add_backend(const Plugin& plugin, const std::map<std::string, std::string>& configured_options,
                              const Options& options, const ModelRegistry& models, std::size_t instances_per_model) {
  BackendState state;
  state.name = plugin.name();
  state.kind = plugin.info().name;
  state.path = plugin.path();
  state.info = plugin.info();
  state.instances_per_model = std::max<std::size_t>(instances_per_model, 1);

  std::map<std::string, std::string> instance_options = configured_options;
  // `workers` sizes the CPU backend unless its own options already do
  if (state.kind == "cpu" && instance_options.count("threads") == 0) {
    instance_options["threads"] = std::to_string(cpu_threads(options.workers));
  }
  state.options = options_text(instance_options);

  Backend backend;
  backend.state = states_.size();
  backend.plugin = &plugin;
  backend.pools.resize(models.capacity());
  backend.model_reason.resize(models.capacity());
  backend.instance_options = std::move(instance_options);
  bool described = false;
  for (const auto& model : models.models()) {
    const std::size_t m = model->index;
    std::vector<std::unique_ptr<PluginInstance>> instances;
    std::string reason = make_instances(backend, state, *model, instances);
    if (!reason.empty()) {
      state.model_problems.push_back("model '" + model->name + "': " + reason);
      backend.model_reason[m] = std::move(reason);
      continue;
    }
    // every instance of a backend gets the same options: the first one speaks for all
    if (!described) {
      described = true;
      // a failure here is shown where the device would be, in the start-up log and server info
      if (Status s = instances.front()->describe(state.description); !s) state.description.device = s.message();
    }
    backend.pools[m] = std::make_unique<InstancePool>(std::move(instances), options.pool);
  }
  state.ready = std::any_of(backend.pools.begin(), backend.pools.end(), [](const auto& p) { return p != nullptr; });
  if (!state.ready) {
    state.reason = models.size() == 0 ? "no models to serve" : "serves no model: " + state.model_problems.front();
  }
  states_.push_back(std::move(state));
  backends_.push_back(std::move(backend));
}

std::string BackendPool::make_instances(const Backend& backend, const BackendState& state, const ServedModel& model,
                                        std::vector<std::unique_ptr<PluginInstance>>& out) const {
  if (state.info.max_nv != 0 && static_cast<std::uint32_t>(model.model.nv) > state.info.max_nv) {
    return "the model has nv " + std::to_string(model.model.nv) + ", the backend takes at most " +
           std::to_string(state.info.max_nv);
  }
  for (std::size_t i = 0; i < state.instances_per_model; ++i) {
    std::unique_ptr<PluginInstance> instance;
    if (Status s = backend.plugin->create_instance(model.desc.desc(), backend.instance_options, instance); !s) {
      out.clear();
      return s.message();
    }
    out.push_back(std::move(instance));
  }
  return "";
}

std::vector<std::string> BackendPool::add_model(const ServedModel& model) {
  std::vector<std::string> problems;
  std::vector<std::pair<BackendState*, std::string>> model_problems;
  for (Backend& backend : backends_) {
    BackendState& state = states_[backend.state];
    // a backend that serves nothing stays unavailable, as it was reported at start-up
    if (!state.ready) continue;
    const std::size_t m = model.index;
    if (m >= backend.pools.size() || backend.pools[m] != nullptr) {
      problems.push_back("backend " + state.name + ": no place for model '" + model.name + "'");
      continue;
    }
    std::vector<std::unique_ptr<PluginInstance>> instances;
    std::string reason = make_instances(backend, state, model, instances);
    if (!reason.empty()) {
      model_problems.emplace_back(&state, "model '" + model.name + "': " + reason);
      problems.push_back("backend " + state.name + ": " + reason);
      backend.model_reason[m] = std::move(reason);
      continue;
    }
    // state.description stays as the start-up instances gave it: requests read it meanwhile
    backend.pools[m] = std::make_unique<InstancePool>(std::move(instances), pool_options_);
  }
  // a model no backend serves is not registered: nothing to report on it later
  if (serves(model))
    for (auto& [state, problem] : model_problems) state->model_problems.push_back(std::move(problem));
  return problems;
}

bool BackendPool::serves(const ServedModel& model) const noexcept {
  return std::any_of(backends_.begin(), backends_.end(), [&](const Backend& b) {
    return model.index < b.pools.size() && b.pools[model.index] != nullptr;
  });
}

std::vector<std::string> BackendPool::model_details(const ServedModel& model) const {
  std::vector<std::string> out;
  for (const Backend& backend : backends_) {
    if (model.index >= backend.pools.size() || backend.pools[model.index] == nullptr) continue;
    const BackendState& state = states_[backend.state];
    InstanceDescription d;
    if (!backend.pools[model.index]->instance(0).describe(d) || d.detail.empty() ||
        d.detail == state.description.detail)
      continue;
    out.push_back("backend " + state.name + ": " + d.detail);
  }
  return out;
}

std::size_t BackendPool::ready_count() const noexcept {
  return static_cast<std::size_t>(std::count_if(states_.begin(), states_.end(), [](const auto& s) { return s.ready; }));
}

const BackendPool::Backend* BackendPool::find(std::string_view name) const noexcept {
  for (const Backend& b : backends_) {
    if (states_[b.state].name == name) return &b;
  }
  return nullptr;
}

const BackendPool::Backend* BackendPool::find_for(std::string_view name, const ServedModel& model) const noexcept {
  if (const Backend* b = find(name)) return b;
  const Backend* first = nullptr;
  for (const Backend& b : backends_) {
    if (states_[b.state].kind != name) continue;
    if (model.index < b.pools.size() && b.pools[model.index] != nullptr) return &b;
    if (first == nullptr) first = &b;
  }
  return first;
}

bool BackendPool::has_kind(std::string_view kind) const noexcept {
  return std::any_of(backends_.begin(), backends_.end(),
                     [&](const Backend& b) { return states_[b.state].kind == kind; });
}

std::vector<std::string> BackendPool::resolve(std::string_view name) const {
  if (find(name) != nullptr) return {std::string(name)};
  std::vector<std::string> out;
  for (const Backend& b : backends_)
    if (states_[b.state].kind == name) out.push_back(states_[b.state].name);
  return out;
}

InstancePool* BackendPool::pool(std::string_view backend, const ServedModel& model) const {
  const Backend* b = find(backend);
  return b == nullptr || model.index >= b->pools.size() ? nullptr : b->pools[model.index].get();
}

const Plugin* BackendPool::plugin(std::string_view backend) const {
  const Backend* b = find(backend);
  return b == nullptr ? nullptr : b->plugin;
}

Status BackendPool::unavailable_backend(std::string_view name) const {
  std::string why = "not configured";
  // the last attempt under this name says most (a later plugin may have replaced an earlier one)
  for (auto it = states_.rbegin(); it != states_.rend(); ++it) {
    if ((it->name == name || it->kind == name) && !it->ready) {
      why = it->reason;
      break;
    }
  }
  return unavailable("backend " + std::string(name) + " is not available: " + why);
}

Status BackendPool::route(const ServedModel& model, std::string_view backend_name, std::uint32_t precision,
                          Route& out) const {
  const Backend* backend = nullptr;
  if (backend_name.empty()) {
    // automatic: the CPU backend, else whichever backend serves the model
    backend = find_for("cpu", model);
    if (backend == nullptr || backend->pools[model.index] == nullptr) {
      backend = nullptr;
      for (const Backend& b : backends_) {
        if (b.pools[model.index] != nullptr) {
          backend = &b;
          break;
        }
      }
    }
    if (backend == nullptr) return unavailable("no backend is available for model '" + model.name + "'");
  } else {
    backend = find_for(backend_name, model);
    if (backend == nullptr) return unavailable_backend(backend_name);
    if (backend->pools[model.index] == nullptr) {
      return unavailable("backend " + std::string(backend_name) + " is not available for model '" + model.name +
                         "': " + backend->model_reason[model.index]);
    }
  }

  const BackendState& state = states_[backend->state];
  const std::uint32_t supported = state.info.precisions;
  if (precision == 0) {
    for (std::uint32_t p : kPrecisionOrder) {
      if (supported & p) {
        precision = p;
        break;
      }
    }
    if (precision == 0) return unavailable("backend " + state.name + " lists no precision");
  } else if ((supported & precision) == 0) {
    return invalid_argument("backend " + state.name + " does not support precision " + precision_label(precision) +
                            " (it supports " + precision_list(supported) + ")");
  }

  out.pool = backend->pools[model.index].get();
  out.plugin = backend->plugin;
  out.backend = &state;
  out.precision = static_cast<rbdgrad_precision>(precision);
  return Status::ok();
}

}  // namespace rbdgrad::server
