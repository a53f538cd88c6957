// Shared by the broken fakes: a complete table of trivial functions, so each fake differs from a
// valid plugin in exactly the one way its name says.
#pragma once

#include "rbdgrad/plugin_api.h"

// the fakes are built with hidden visibility: only what is marked here is exported, as in a backend
#define FAKE_EXPORT extern "C" __attribute__((visibility("default")))

namespace fake {

inline rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  info->name = "broken";
  info->version = "0";
  info->precisions = RBDGRAD_PRECISION_F64;
  info->outputs = RBDGRAD_OUTPUT_QDD;
  return nullptr;
}
inline rbdgrad_error* can_run(const rbdgrad_model_desc*, uint32_t, uint32_t, uint64_t) { return nullptr; }
inline rbdgrad_error* create_instance(const rbdgrad_model_desc*, const rbdgrad_options*, rbdgrad_instance**) {
  return nullptr;
}
inline rbdgrad_error* compute(rbdgrad_instance*, const rbdgrad_batch*) { return nullptr; }
inline void destroy_instance(rbdgrad_instance*) {}
inline uint32_t error_code(const rbdgrad_error*) { return RBDGRAD_ERROR_INTERNAL; }
inline const char* error_message(const rbdgrad_error*) { return ""; }
inline void error_delete(rbdgrad_error*) {}

constexpr rbdgrad_plugin_api valid_table() {
  return {sizeof(rbdgrad_plugin_api), RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
          &get_info, &can_run, &create_instance, &compute, &destroy_instance,
          &error_code, &error_message, &error_delete, nullptr, nullptr};
}

}  // namespace fake
