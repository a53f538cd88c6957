// A shared library that is no plugin: it exports a function, but not rbdgrad_plugin_entry.
#include "fake_table.hpp"

FAKE_EXPORT const rbdgrad_plugin_api* rbdgrad_plugin_entri(uint32_t, uint32_t) { return nullptr; }
