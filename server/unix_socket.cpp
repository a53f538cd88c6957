// Stale-socket detection by connecting: a refused connection means nobody listens there.
#include "unix_socket.hpp"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace rbdgrad::server {

Status free_unix_socket_path(const std::string& path) {
  sockaddr_un addr{};
  if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
    return invalid_argument("unix socket path '" + path + "' must have 1 to " +
                            std::to_string(sizeof(addr.sun_path) - 1) + " characters");
  }
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return Status::ok();
    return failed_precondition("unix socket path '" + path + "': " + std::strerror(errno));
  }
  if (!S_ISSOCK(st.st_mode)) return failed_precondition("unix socket path '" + path + "' exists and is not a socket");

  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return failed_precondition(std::string("cannot create a probe socket: ") + std::strerror(errno));
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int rc = connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  const int err = errno;
  close(fd);
  if (rc == 0) return failed_precondition("unix socket '" + path + "' is in use by another process");
  if (err != ECONNREFUSED) {
    return failed_precondition("unix socket '" + path + "' exists and cannot be probed: " + std::strerror(err));
  }
  // nobody listens: the file of a daemon that did not clean up
  if (unlink(path.c_str()) != 0 && errno != ENOENT) {
    return failed_precondition("cannot remove the stale unix socket '" + path + "': " + std::strerror(errno));
  }
  return Status::ok();
}

ino_t socket_inode(const std::string& path) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0 || !S_ISSOCK(st.st_mode)) return 0;
  return st.st_ino;
}

bool remove_own_socket(const std::string& path, ino_t inode) {
  if (inode == 0 || socket_inode(path) != inode) return false;
  return unlink(path.c_str()) == 0;
}

}  // namespace rbdgrad::server
