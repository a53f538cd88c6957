// A backend that fails on purpose, for the soak test (issue 9): it forwards every call to the CPU
// plugin (option `inner`: its path) and, per compute call, at random (seeded per instance):
//   error_permille  fails the whole call with RBDGRAD_ERROR_UNAVAILABLE "injected device error";
//   slow_permille   sleeps slow_ms before computing;
//   hang_permille   sleeps hang_ms before computing (a backend that stops answering for a while).
// It calls itself "cuda", so that the daemon routes to it what it would route to a GPU (the
// threshold policy's large batches, the cuda hint): a flaky GPU backend stand-in.
#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "rbdgrad/plugin_api.h"

struct rbdgrad_error {
  rbdgrad_error_code code;
  std::string message;
};

struct rbdgrad_instance {
  rbdgrad_instance* inner = nullptr;
  unsigned error_permille = 0, slow_permille = 0, hang_permille = 0;
  unsigned slow_ms = 0, hang_ms = 0;
  std::mt19937 rng;
};

namespace {

const rbdgrad_plugin_api* g_inner = nullptr;
std::atomic<unsigned> g_seed{1};

rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) {
  return new rbdgrad_error{code, std::move(message)};
}

// an inner error, copied into one of ours (the host frees it with our error_delete)
rbdgrad_error* adopt(rbdgrad_error* inner) {
  if (inner == nullptr) return nullptr;
  rbdgrad_error* e = make_error(static_cast<rbdgrad_error_code>(g_inner->error_code(inner)), g_inner->error_message(inner));
  g_inner->error_delete(inner);
  return e;
}

rbdgrad_error* load_inner(const char* path) {
  if (g_inner != nullptr) return nullptr;
  void* library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (library == nullptr) return make_error(RBDGRAD_ERROR_UNAVAILABLE, std::string("cannot load inner: ") + dlerror());
  auto entry = reinterpret_cast<rbdgrad_plugin_entry_fn>(dlsym(library, RBDGRAD_PLUGIN_ENTRY_SYMBOL));
  g_inner = entry ? entry(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR) : nullptr;
  return g_inner ? nullptr : make_error(RBDGRAD_ERROR_UNAVAILABLE, "the inner plugin refused this host");
}

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  info->name = "cuda";
  info->version = "0.0-fault";
  info->precisions = RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32;
  info->outputs = 0xff;
  info->max_batch = 0;
  info->max_nv = 0;
  return nullptr;
}

rbdgrad_error* can_run(const rbdgrad_model_desc*, uint32_t precision, uint32_t, uint64_t n) {
  if ((precision & (RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32)) == 0)
    return make_error(RBDGRAD_ERROR_UNSUPPORTED, "f64 and f32 only");
  if (n == 0) return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "n is 0");
  return nullptr;
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* model, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  auto made = std::make_unique<rbdgrad_instance>();
  std::string inner_path;
  std::vector<const char*> keys, values;  // the inner plugin's options: none but threads
  for (size_t i = 0; options != nullptr && i < options->count; ++i) {
    const std::string key = options->keys[i];
    const unsigned value = static_cast<unsigned>(std::strtoul(options->values[i], nullptr, 10));
    if (key == "inner") inner_path = options->values[i];
    else if (key == "error_permille") made->error_permille = value;
    else if (key == "slow_permille") made->slow_permille = value;
    else if (key == "hang_permille") made->hang_permille = value;
    else if (key == "slow_ms") made->slow_ms = value;
    else if (key == "hang_ms") made->hang_ms = value;
    else if (key == "threads") keys.push_back("threads"), values.push_back(options->values[i]);
    else return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "unknown option '" + key + "'");
  }
  if (inner_path.empty()) return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "option 'inner' (the CPU plugin) is required");
  if (rbdgrad_error* e = load_inner(inner_path.c_str())) return e;
  const rbdgrad_options inner_options{sizeof(rbdgrad_options), keys.size(), keys.data(), values.data()};
  if (rbdgrad_error* e = g_inner->create_instance(model, &inner_options, &made->inner)) return adopt(e);
  made->rng.seed(g_seed.fetch_add(1));
  *instance = made.release();
  return nullptr;
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  const unsigned draw = std::uniform_int_distribution<unsigned>(0, 999)(instance->rng);
  if (draw < instance->error_permille) return make_error(RBDGRAD_ERROR_UNAVAILABLE, "injected device error");
  if (draw < instance->error_permille + instance->hang_permille)
    std::this_thread::sleep_for(std::chrono::milliseconds(instance->hang_ms));
  else if (draw < instance->error_permille + instance->hang_permille + instance->slow_permille)
    std::this_thread::sleep_for(std::chrono::milliseconds(instance->slow_ms));
  return adopt(g_inner->compute(instance->inner, batch));
}

void destroy_instance(rbdgrad_instance* instance) {
  if (instance == nullptr) return;
  if (instance->inner) g_inner->destroy_instance(instance->inner);
  delete instance;
}

uint32_t error_code(const rbdgrad_error* e) { return e ? static_cast<uint32_t>(e->code) : 0; }
const char* error_message(const rbdgrad_error* e) { return e ? e->message.c_str() : ""; }
void error_delete(rbdgrad_error* e) { delete e; }

const rbdgrad_plugin_api kApi = {
    sizeof(rbdgrad_plugin_api), RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
    &get_info, &can_run, &create_instance, &compute, &destroy_instance, &error_code, &error_message, &error_delete,
    nullptr, nullptr};

}  // namespace

extern "C" __attribute__((visibility("default"))) const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t major,
                                                                                                uint32_t) {
  return major == RBDGRAD_PLUGIN_API_MAJOR ? &kApi : nullptr;
}
