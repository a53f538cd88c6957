// A plugin built for plugin API 99.0 that does not check the host's version: the host must refuse.
#include "fake_table.hpp"

namespace {
constexpr rbdgrad_plugin_api kTable = [] {
  rbdgrad_plugin_api table = fake::valid_table();
  table.api_major = 99;
  table.api_minor = 0;
  return table;
}();
}  // namespace

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t, uint32_t) { return &kTable; }
