// The ready file (rbdgradd --ready-file PATH): written once the daemon serves, so that scripts and
// tests that start it on port 0 learn where it listens. One address per line, "tcp HOST:PORT" or
// "unix PATH", written to a temporary file and renamed: a reader never sees half of it.
#pragma once

#include <string>
#include <vector>

#include "listen_address.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

/// Writes `addresses` to `path` atomically (PATH.tmp.<pid>, then rename). not_found when the
/// directory cannot be written; the temporary file is removed on failure.
Status write_ready_file(const std::string& path, const std::vector<ListenAddress>& addresses);

}  // namespace rbdgrad::server
