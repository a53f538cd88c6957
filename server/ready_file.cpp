// Atomic write of the ready file.
#include "ready_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace rbdgrad::server {

Status write_ready_file(const std::string& path, const std::vector<ListenAddress>& addresses) {
  const std::string tmp = path + ".tmp." + std::to_string(getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return not_found("cannot write the ready file '" + tmp + "': " + std::strerror(errno));
    for (const ListenAddress& a : addresses) out << a.text() << "\n";
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      return not_found("cannot write the ready file '" + tmp + "'");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    return not_found("cannot rename the ready file to '" + path + "': " + std::strerror(err));
  }
  return Status::ok();
}

}  // namespace rbdgrad::server
