// The version check every plugin's entry point makes before it hands out its function table.
#pragma once

#include <cstdint>

namespace rbdgrad::plugin {

/// True when the host speaks this plugin's API: the same major version and a minor version of at
/// least `min_host_minor`. Otherwise writes why to stderr, naming `plugin` ("cpu"), since the
/// ABI gives the entry point no other channel, and returns false.
/// When compatible, also records host_minor for host_api_minor().
bool host_api_compatible(const char* plugin, std::uint32_t host_major, std::uint32_t host_minor,
                         std::uint32_t min_host_minor) noexcept;

/// The minor API version of the host that took this plugin's table, so that codes added later
/// are sent only to hosts that know them; this build's own minor until an entry point is called
/// (code linked straight into a test speaks this build's API).
std::uint32_t host_api_minor() noexcept;

}  // namespace rbdgrad::plugin
