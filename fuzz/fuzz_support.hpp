// What the harnesses share: a verbose switch, the abort that makes a broken invariant a finding,
// and the plugin table's errors taken as the ABI says.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "rbdgrad/plugin_api.h"

namespace rbdgrad::fuzz {

/// RBDGRAD_FUZZ_VERBOSE=1: each input's outcome on stderr (to see what a reproducer does).
inline bool verbose() {
  static const bool on = std::getenv("RBDGRAD_FUZZ_VERBOSE") != nullptr;
  return on;
}

/// A finding: "<fuzzer>: <what>: <detail>" on stderr, then abort (libFuzzer saves the input).
[[noreturn]] inline void fail(const char* fuzzer, const char* what, const std::string& detail) {
  std::fprintf(stderr, "%s: %s: %s\n", fuzzer, what, detail.c_str());
  std::abort();
}

/// An error from the plugin table: its code and message, released as the ABI says.
struct PluginError {
  std::uint32_t code = RBDGRAD_OK;
  std::string message;
};

inline PluginError take(const rbdgrad_plugin_api& api, rbdgrad_error* e) {
  PluginError out;
  if (e == nullptr) return out;
  out.code = api.error_code(e);
  out.message = api.error_message(e);
  api.error_delete(e);
  return out;
}

}  // namespace rbdgrad::fuzz
