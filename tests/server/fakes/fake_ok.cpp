// A valid backend for the loader tests: name "fake", f64 qdd only (qdd = 1), with scripted failures
// that exercise the host's error conversion:
//   n == 3        state 2 fails: RBDGRAD_ERROR_NUMERICAL "state 2: boom", the others are computed
//   n == 100 + c  fails with error code c (1..7: the enum's range), message "scripted"
// It counts the errors it makes and deletes, read through fake_ok_error_counts.
#include <atomic>
#include <cstring>
#include <string>

#include "fake_table.hpp"

struct rbdgrad_error {
  rbdgrad_error_code code;
  std::string message;
};

struct rbdgrad_instance {
  uint32_t nv;
};

namespace {

std::atomic<int> g_errors_made{0};
std::atomic<int> g_errors_deleted{0};

rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) {
  ++g_errors_made;
  return new rbdgrad_error{code, std::move(message)};
}

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  info->name = "fake";
  info->version = "0.1.0";
  info->precisions = RBDGRAD_PRECISION_F64;
  info->outputs = RBDGRAD_OUTPUT_QDD;
  info->max_batch = 1000;
  info->max_nv = 8;
  return nullptr;
}

rbdgrad_error* can_run(const rbdgrad_model_desc* model, uint32_t precision, uint32_t outputs, uint64_t n) {
  if (precision != RBDGRAD_PRECISION_F64) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "f64 only");
  if (outputs != RBDGRAD_OUTPUT_QDD) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "qdd only");
  if (model->nv > 8 || n > 1000) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "too large");
  return nullptr;
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* model, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  for (size_t i = 0; i < options->count; ++i) {
    if (std::strcmp(options->keys[i], "threads") != 0) {
      return make_error(RBDGRAD_ERROR_INVALID_ARGUMENT, std::string("unknown option '") + options->keys[i] + "'");
    }
  }
  *instance = new rbdgrad_instance{model->nv};
  return nullptr;
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  if (batch->n > 100) return make_error(static_cast<rbdgrad_error_code>(batch->n - 100), "scripted");
  if (batch->precision != RBDGRAD_PRECISION_F64) return make_error(RBDGRAD_ERROR_UNSUPPORTED, "f64 only");
  auto* qdd = static_cast<double*>(batch->qdd);
  for (uint64_t k = 0; k < batch->n * instance->nv; ++k) qdd[k] = 1.0;
  if (batch->n == 3) {
    if (batch->state_status != nullptr) batch->state_status[2] = RBDGRAD_ERROR_NUMERICAL;
    return make_error(RBDGRAD_ERROR_NUMERICAL, "state 2: boom");
  }
  return nullptr;
}

void destroy_instance(rbdgrad_instance* instance) { delete instance; }
uint32_t error_code(const rbdgrad_error* error) { return static_cast<uint32_t>(error->code); }
const char* error_message(const rbdgrad_error* error) { return error->message.c_str(); }
void error_delete(rbdgrad_error* error) {
  ++g_errors_deleted;
  delete error;
}

const rbdgrad_plugin_api kTable = {sizeof(rbdgrad_plugin_api), RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
                                   &get_info, &can_run, &create_instance, &compute, &destroy_instance,
                                   &error_code, &error_message, &error_delete, nullptr, nullptr};

}  // namespace

// needs nothing beyond API 1.0, so any 1.x host will do
FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t host_major, uint32_t /*host_minor*/) {
  if (host_major != RBDGRAD_PLUGIN_API_MAJOR) return nullptr;
  return &kTable;
}

FAKE_EXPORT void fake_ok_error_counts(int* made, int* deleted) {
  *made = g_errors_made;
  *deleted = g_errors_deleted;
}
