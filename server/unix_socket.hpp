// The Unix-domain socket file of the daemon: freeing its path before listening (a daemon that
// crashed leaves its socket file behind) without ever taking the socket of a live daemon, and
// removing it at exit.
#pragma once

#include <string>
#include <sys/types.h>

#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

/// Makes `path` usable for a new listening socket. Nothing there: ok. A socket nobody accepts on
/// (stale): removed, ok. A socket a process listens on: failed_precondition "... is in use by
/// another process". Anything else (a regular file, a directory): failed_precondition "... exists
/// and is not a socket". A path too long for sockaddr_un: invalid_argument.
Status free_unix_socket_path(const std::string& path);

/// The inode of the socket file at `path`, 0 if there is none (to recognise our own file later).
ino_t socket_inode(const std::string& path);

/// Removes `path` if it is still the socket with inode `inode` (and not one that another daemon
/// created since). Best effort: true if removed.
bool remove_own_socket(const std::string& path, ino_t inode);

}  // namespace rbdgrad::server
