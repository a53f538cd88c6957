// A plugin that refuses every host version (its entry point returns NULL).
#include "fake_table.hpp"

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entry(uint32_t, uint32_t) { return nullptr; }
