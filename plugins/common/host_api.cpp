#include "host_api.hpp"

#include <cstdio>

#include "rbdgrad/plugin_api.h"

namespace rbdgrad::plugin {

bool host_api_compatible(const char* plugin, std::uint32_t host_major, std::uint32_t host_minor,
                         std::uint32_t min_host_minor) noexcept {
  if (host_major == RBDGRAD_PLUGIN_API_MAJOR && host_minor >= min_host_minor) return true;
  std::fprintf(stderr, "rbdgrad %s plugin: host plugin API %u.%u is not compatible with %d.%d (needs major %d, minor >= %u)\n",
               plugin, host_major, host_minor, RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR,
               RBDGRAD_PLUGIN_API_MAJOR, min_host_minor);
  return false;
}

}  // namespace rbdgrad::plugin
