// A fake "cuda" backend for the daemon's routing and service tests: f64 and f32 only, every output
// but M. It computes nothing real: output element e of state k is k + e / 1000 (exactly
// predictable), in the batch's precision. Scripted by the inputs:
//   u[k][0] == 777     state k fails RBDGRAD_ERROR_NUMERICAL ("state k: scripted numerical failure");
//                      the others are computed
//   q[0][0] == -999    the batch fails RBDGRAD_ERROR_UNAVAILABLE "device lost"
//   q[0][0] == 4242    the batch takes 300 ms (an in-flight request for the shutdown tests)
// Instance options: "device" (any value); other keys are RBDGRAD_ERROR_INVALID_ARGUMENT.
// describe_instance: detail "kernel for nv N", the model's nv (as the real plugin names the kernel
// each model got).
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

#include "fake_table.hpp"

struct rbdgrad_error {
  rbdgrad_error_code code;
  std::string message;
};

struct rbdgrad_instance {
  uint32_t nv;
  std::string detail;
};

namespace {

constexpr uint32_t kPrecisions = RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32;
constexpr uint32_t kOutputs = 127;  // all eight but RBDGRAD_OUTPUT_M (128)

rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) {
  return new rbdgrad_error{code, std::move(message)};
}

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  info->name = "cuda";
  info->version = "0.0-fake";
  info->precisions = kPrecisions;
  info->outputs = kOutputs;
  info->max_batch = 0;
  info->max_nv = 0;
  return nullptr;
}

rbdgrad_error* can_run(const rbdgrad_model_desc*, uint32_t precision, uint32_t outputs, uint64_t n) {
  if ((precision & kPrecisions) == 0) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "f64 and f32 only");
  if ((outputs & ~kOutputs) != 0) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "output M is not supported");
  if (n == 0) return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "n is 0");
  return nullptr;
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* model, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  for (size_t i = 0; options != nullptr && i < options->count; ++i) {
    if (std::strcmp(options->keys[i], "device") != 0) {
      return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, std::string("unknown option '") + options->keys[i] + "'");
    }
  }
  *instance = new rbdgrad_instance{model->nv, "kernel for nv " + std::to_string(model->nv)};
  return nullptr;
}

template <class S>
rbdgrad_error* compute_typed(uint32_t nv, const rbdgrad_batch* b) {
  const auto* q = static_cast<const S*>(b->q);
  const auto* u = static_cast<const S*>(b->u);
  if (q[0] == S(-999)) return make_error(RBDGRAD_ERROR_UNAVAILABLE, "device lost");
  if (q[0] == S(4242)) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  void* outputs[8] = {b->qdd, b->minv_out, b->dqdd_dq, b->dqdd_dqd, b->tau, b->dtau_dq, b->dtau_dqd, b->m};
  for (int o = 0; o < 8; ++o) {
    if ((b->outputs & (1u << o)) == 0) continue;
    const uint64_t per_state = (o == 0 || o == 4) ? nv : uint64_t{nv} * nv;  // qdd and tau are vectors
    auto* out = static_cast<S*>(outputs[o]);
    for (uint64_t k = 0; k < b->n; ++k) {
      for (uint64_t e = 0; e < per_state; ++e) out[k * per_state + e] = S(k) + S(e) / S(1000);
    }
  }
  int64_t first_failed = -1;
  for (uint64_t k = 0; k < b->n; ++k) {
    const bool fails = u[k * nv] == S(777);
    if (b->state_status != nullptr) b->state_status[k] = fails ? RBDGRAD_ERROR_NUMERICAL : RBDGRAD_OK;
    if (fails && first_failed < 0) first_failed = static_cast<int64_t>(k);
  }
  if (first_failed >= 0) {
    return make_error(RBDGRAD_ERROR_NUMERICAL, "state " + std::to_string(first_failed) + ": scripted numerical failure");
  }
  return nullptr;
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  if (batch->precision == RBDGRAD_PRECISION_F64) return compute_typed<double>(instance->nv, batch);
  if (batch->precision == RBDGRAD_PRECISION_F32) return compute_typed<float>(instance->nv, batch);
  return make_error(RBDGRAD_ERROR_UNSUPPORTED, "f64 and f32 only");
}

void destroy_instance(rbdgrad_instance* instance) { delete instance; }
rbdgrad_error* describe_instance(const rbdgrad_instance* instance, rbdgrad_instance_info* info) {
  info->mode = "";
  info->device = "";
  if (info->struct_size >= sizeof(rbdgrad_instance_info)) info->detail = instance->detail.c_str();
  return nullptr;
}
uint32_t error_code(const rbdgrad_error* error) { return static_cast<uint32_t>(error->code); }
const char* error_message(const rbdgrad_error* error) { return error->message.c_str(); }
void error_delete(rbdgrad_error* error) { delete error; }

const rbdgrad_plugin_api kTable = {sizeof(rbdgrad_plugin_api), RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
                                   &get_info, &can_run, &create_instance, &compute, &destroy_instance,
                                   &error_code, &error_message, &error_delete, &describe_instance, nullptr};

}  // namespace

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t host_major, uint32_t /*host_minor*/) {
  if (host_major != RBDGRAD_PLUGIN_API_MAJOR) return nullptr;
  return &kTable;
}
