#include "host_api.hpp"

#include <atomic>
#include <cstdio>

#include "rbdgrad/plugin_api.h"

namespace rbdgrad::plugin {
namespace {
std::atomic<std::uint32_t> g_host_minor{RBDGRAD_PLUGIN_API_MINOR};
}  // namespace

std::uint32_t host_api_minor() noexcept { return g_host_minor.load(std::memory_order_relaxed); }

bool host_api_compatible(const char* plugin, std::uint32_t host_major, std::uint32_t host_minor,
                         std::uint32_t min_host_minor) noexcept {
  if (host_major == RBDGRAD_PLUGIN_API_MAJOR && host_minor >= min_host_minor) {
    g_host_minor.store(host_minor, std::memory_order_relaxed);
    return true;
  }
  std::fprintf(stderr, "rbdgrad %s plugin: host plugin API %u.%u is not compatible with %d.%d (needs major %d, minor >= %u)\n",
               plugin, host_major, host_minor, RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
               RBDGRAD_PLUGIN_API_MAJOR, min_host_minor);
  return false;
}

}  // namespace rbdgrad::plugin
