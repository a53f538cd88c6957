// A plugin whose table says it ends before compute (shorter than the v1.0 table): refused.
#include <cstddef>

#include "fake_table.hpp"

namespace {
constexpr rbdgrad_plugin_api kTable = [] {
  rbdgrad_plugin_api table = fake::valid_table();
  table.struct_size = offsetof(rbdgrad_plugin_api, compute);
  return table;
}();
}  // namespace

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t, uint32_t) { return &kTable; }
