// A fake backend with a latency the test chooses, for the scheduler's tests: built three times
// with FAKE_NAME "cpu", "cuda" and "fpga" (tests/server/CMakeLists.txt), the fpga one in Q16.16
// only and with a latency model of its own (API 1.2 estimate_latency), the others in f64 and f32.
// compute sleeps fixed_us + per_state_us * n microseconds (instance options, default 0) and
// writes output element e of state k as k + e / 1000 (exactly predictable; raw k * 65536 + e in
// Q16.16). estimate_latency (fpga only) answers fixed_us + per_state_us * n without sleeping.
// With the option fail_on_marker=1, a batch whose first q is -999 fails as a whole,
// RBDGRAD_ERROR_UNAVAILABLE "device lost" (a lost device, for the failover tests). With the option
// hang_us=T, a batch whose first q is -998 sleeps T microseconds before it computes (a hung
// device, bounded so that the daemon can stop). Any state whose first q is -997 fails alone,
// RBDGRAD_ERROR_NUMERICAL "state K: singular mass matrix" (K numbered within the batch).
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <thread>

#include "fake_table.hpp"

#ifndef FAKE_NAME
#error "FAKE_NAME must be defined"
#endif

struct rbdgrad_error {
  rbdgrad_error_code code;
  std::string message;
};

struct rbdgrad_instance {
  uint32_t nv;
  double fixed_us = 0;
  double per_state_us = 0;
  bool fail_on_marker = false;
  double hang_us = 0;
};

namespace {

constexpr bool kFpga = std::string_view(FAKE_NAME) == "fpga";
constexpr uint32_t kPrecisions =
    kFpga ? RBDGRAD_PRECISION_FIXED_Q16_16 : RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32;

rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) {
  return new rbdgrad_error{code, std::move(message)};
}

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  info->name = FAKE_NAME;
  info->version = "0.0-timed";
  info->precisions = kPrecisions;
  info->outputs = 255;
  info->max_batch = 0;
  info->max_nv = 0;
  return nullptr;
}

rbdgrad_error* can_run(const rbdgrad_model_desc*, uint32_t precision, uint32_t, uint64_t n) {
  if ((precision & kPrecisions) == 0) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "not this precision");
  if (n == 0) return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "n is 0");
  return nullptr;
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* model, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  auto* made = new rbdgrad_instance{model->nv};
  for (size_t i = 0; options != nullptr && i < options->count; ++i) {
    const std::string key = options->keys[i];
    if (key == "fixed_us") {
      made->fixed_us = std::strtod(options->values[i], nullptr);
    } else if (key == "per_state_us") {
      made->per_state_us = std::strtod(options->values[i], nullptr);
    } else if (key == "hang_us") {
      made->hang_us = std::strtod(options->values[i], nullptr);
    } else if (key == "fail_on_marker") {
      made->fail_on_marker = std::string(options->values[i]) == "1";
    } else if (key != "threads") {  // the daemon gives the backend named cpu its thread count
      delete made;
      return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, "unknown option '" + key + "'");
    }
  }
  *instance = made;
  return nullptr;
}

template <class S>
void fill(const rbdgrad_batch* b, uint32_t nv) {
  void* outputs[8] = {b->qdd, b->minv_out, b->dqdd_dq, b->dqdd_dqd, b->tau, b->dtau_dq, b->dtau_dqd, b->m};
  for (int o = 0; o < 8; ++o) {
    if ((b->outputs & (1u << o)) == 0) continue;
    const uint64_t per_state = (o == 0 || o == 4) ? nv : uint64_t{nv} * nv;
    auto* out = static_cast<S*>(outputs[o]);
    for (uint64_t k = 0; k < b->n; ++k)
      for (uint64_t e = 0; e < per_state; ++e) out[k * per_state + e] = S(k) + S(e) / S(1000);
  }
}

bool has_marker(const rbdgrad_batch* b, int marker) {
  if (b->precision == RBDGRAD_PRECISION_F64) return static_cast<const double*>(b->q)[0] == marker;
  if (b->precision == RBDGRAD_PRECISION_F32) return static_cast<const float*>(b->q)[0] == static_cast<float>(marker);
  return static_cast<const int32_t*>(b->q)[0] == marker * 65536;
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  if (instance->fail_on_marker && has_marker(batch, -999)) return make_error(RBDGRAD_ERROR_UNAVAILABLE, "device lost");
  if (instance->hang_us > 0 && has_marker(batch, -998))
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int64_t>(instance->hang_us)));
  const double us = instance->fixed_us + instance->per_state_us * static_cast<double>(batch->n);
  if (us > 0) std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int64_t>(us)));
  if (batch->precision == RBDGRAD_PRECISION_F64) {
    fill<double>(batch, instance->nv);
  } else if (batch->precision == RBDGRAD_PRECISION_F32) {
    fill<float>(batch, instance->nv);
  } else {
    void* outputs[8] = {batch->qdd, batch->minv_out, batch->dqdd_dq, batch->dqdd_dqd, batch->tau, batch->dtau_dq,
                        batch->dtau_dqd, batch->m};
    for (int o = 0; o < 8; ++o) {
      if ((batch->outputs & (1u << o)) == 0) continue;
      const uint64_t per_state = (o == 0 || o == 4) ? instance->nv : uint64_t{instance->nv} * instance->nv;
      auto* out = static_cast<int32_t*>(outputs[o]);
      for (uint64_t k = 0; k < batch->n; ++k)
        for (uint64_t e = 0; e < per_state; ++e) out[k * per_state + e] = static_cast<int32_t>(k * 65536 + e);
    }
  }
  const size_t stride = instance->nv;
  for (uint64_t k = 0; k < batch->n; ++k) {
    rbdgrad_batch one = *batch;
    const size_t scalar = batch->precision == RBDGRAD_PRECISION_F64 ? sizeof(double) : sizeof(float);
    one.q = static_cast<const char*>(batch->q) + k * stride * scalar;
    if (!has_marker(&one, -997)) {
      if (batch->state_status != nullptr) batch->state_status[k] = RBDGRAD_OK;
      continue;
    }
    if (batch->state_status != nullptr) batch->state_status[k] = RBDGRAD_ERROR_NUMERICAL;
    return make_error(RBDGRAD_ERROR_NUMERICAL, "state " + std::to_string(k) + ": singular mass matrix");
  }
  return nullptr;
}

rbdgrad_error* estimate_latency(const rbdgrad_instance* instance, uint32_t precision, uint32_t, uint64_t n,
                                double* us) {
  if ((precision & kPrecisions) == 0) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "not this precision");
  *us = instance->fixed_us + instance->per_state_us * static_cast<double>(n);
  return nullptr;
}

void destroy_instance(rbdgrad_instance* instance) { delete instance; }
uint32_t error_code(const rbdgrad_error* error) { return static_cast<uint32_t>(error->code); }
const char* error_message(const rbdgrad_error* error) { return error->message.c_str(); }
void error_delete(rbdgrad_error* error) { delete error; }

const rbdgrad_plugin_api kTable = {sizeof(rbdgrad_plugin_api),
                                   RBDGRAD_PLUGIN_API_MAJOR,
                                   RBDGRAD_PLUGIN_API_MINOR,
                                   &get_info,
                                   &can_run,
                                   &create_instance,
                                   &compute,
                                   &destroy_instance,
                                   &error_code,
                                   &error_message,
                                   &error_delete,
                                   nullptr,
                                   kFpga ? &estimate_latency : nullptr};

}  // namespace

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t host_major, uint32_t /*host_minor*/) {
  if (host_major != RBDGRAD_PLUGIN_API_MAJOR) return nullptr;
  return &kTable;
}
