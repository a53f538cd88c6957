// A plugin whose table has no compute function: the host must refuse it at load, not crash later.
#include "fake_table.hpp"

namespace {
constexpr rbdgrad_plugin_api kTable = [] {
  rbdgrad_plugin_api table = fake::valid_table();
  table.compute = nullptr;
  return table;
}();
}  // namespace

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t, uint32_t) { return &kTable; }
