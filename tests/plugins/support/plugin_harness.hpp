// Test harness for backend plugins: loads a plugin as the daemon does (dlopen with RTLD_NOW |
// RTLD_LOCAL), owns instances and errors, and holds the arrays of one batch.
#pragma once

#include <dlfcn.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/batch_view.hpp"
#include "rbdgrad/plugin_api.h"

namespace rbdgrad::testing {

// The plugin's entry point, loaded once per process and never closed (instances and worker threads
// of one test must not outlive the code they run).
inline rbdgrad_plugin_entry_fn load_plugin_entry(const char* path) {
  void* handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) throw std::runtime_error(std::string("dlopen failed: ") + dlerror());
  void* symbol = dlsym(handle, RBDGRAD_PLUGIN_ENTRY_SYMBOL);
  if (symbol == nullptr) throw std::runtime_error(std::string("dlsym failed: ") + dlerror());
  return reinterpret_cast<rbdgrad_plugin_entry_fn>(symbol);
}

// An error taken from the plugin (and released through its table).
struct PluginError {
  rbdgrad_error_code code;  // converted from the table's uint32_t
  std::string message;
};

inline std::optional<PluginError> take(const rbdgrad_plugin_api* api, rbdgrad_error* e) {
  if (e == nullptr) return std::nullopt;
  PluginError out{static_cast<rbdgrad_error_code>(api->error_code(e)), api->error_message(e)};
  api->error_delete(e);
  return out;
}

// An instance destroyed through the table.
struct InstanceDeleter {
  const rbdgrad_plugin_api* api;
  void operator()(rbdgrad_instance* i) const { api->destroy_instance(i); }
};
using InstancePtr = std::unique_ptr<rbdgrad_instance, InstanceDeleter>;

// create_instance with key/value options; the error, if any, in `error`.
inline InstancePtr create(const rbdgrad_plugin_api* api, const rbdgrad_model_desc& desc,
                          const std::vector<std::pair<std::string, std::string>>& options,
                          std::optional<PluginError>* error = nullptr) {
  std::vector<const char*> keys, values;
  for (const auto& [k, v] : options) {
    keys.push_back(k.c_str());
    values.push_back(v.c_str());
  }
  const rbdgrad_options o{sizeof(rbdgrad_options), options.size(), keys.data(), values.data()};
  rbdgrad_instance* instance = nullptr;
  std::optional<PluginError> e = take(api, api->create_instance(&desc, &o, &instance));
  if (error) *error = e;
  return InstancePtr(e ? nullptr : instance, InstanceDeleter{api});
}

// The arrays of one batch in the storage type Raw (double, float, int32_t raw Q16.16), sized for
// n states of nv joints, outputs prefilled with a marker so that untouched slots show.
template <class Raw>
struct BatchArrays {
  BatchArrays(std::size_t states, int joints) : n(states), nv(static_cast<std::size_t>(joints)) {
    const std::size_t vec = n * nv, mat = vec * nv;
    q.assign(vec, Raw(0));
    qd.assign(vec, Raw(0));
    u.assign(vec, Raw(0));
    minv.assign(mat, Raw(0));
    fext.assign(6 * vec, Raw(0));
    for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1)
      out(flag).assign((flag & plugin::kMatrixOutputs) ? mat : vec, Raw(77));
    state_status.assign(n, -1);
  }

  std::vector<Raw>& out(std::uint32_t flag) { return outputs[index(flag)]; }
  const std::vector<Raw>& out(std::uint32_t flag) const { return outputs[index(flag)]; }

  // A batch over these arrays: every output pointer set (the plugin writes only what `outputs` asks).
  rbdgrad_batch batch(std::uint32_t precision, std::uint32_t input_kind, std::uint32_t outputs_flags,
                      bool with_minv, bool with_fext) {
    rbdgrad_batch b{};
    b.struct_size = sizeof(b);
    b.n = n;
    b.precision = precision;
    b.input_kind = input_kind;
    b.outputs = outputs_flags;
    b.q = q.data();
    b.qd = qd.data();
    b.u = u.data();
    b.minv = with_minv ? minv.data() : nullptr;
    b.fext = with_fext ? fext.data() : nullptr;
    b.qdd = out(RBDGRAD_OUTPUT_QDD).data();
    b.minv_out = out(RBDGRAD_OUTPUT_MINV).data();
    b.dqdd_dq = out(RBDGRAD_OUTPUT_DQDD_DQ).data();
    b.dqdd_dqd = out(RBDGRAD_OUTPUT_DQDD_DQD).data();
    b.tau = out(RBDGRAD_OUTPUT_TAU).data();
    b.dtau_dq = out(RBDGRAD_OUTPUT_DTAU_DQ).data();
    b.dtau_dqd = out(RBDGRAD_OUTPUT_DTAU_DQD).data();
    b.m = out(RBDGRAD_OUTPUT_M).data();
    b.state_status = state_status.data();
    return b;
  }

  std::size_t n, nv;
  std::vector<Raw> q, qd, u, minv, fext;
  std::vector<std::int32_t> state_status;

 private:
  static std::size_t index(std::uint32_t flag) {
    std::size_t i = 0;
    while ((1u << i) != flag) ++i;
    return i;
  }
  std::vector<Raw> outputs[8];
};

}  // namespace rbdgrad::testing
