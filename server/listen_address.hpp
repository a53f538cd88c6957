// An address the daemon listens on, as logged and as written to the ready file.
#pragma once

#include <string>

namespace rbdgrad::server {

struct ListenAddress {
  std::string kind;     // "tcp" or "unix"
  std::string address;  // "127.0.0.1:41234" (the bound port, never 0) or the socket path

  /// "tcp 127.0.0.1:41234", "unix /tmp/rbdgradd.sock"
  std::string text() const { return kind + " " + address; }
  /// What a gRPC client dials: "127.0.0.1:41234", "unix:/tmp/rbdgradd.sock"
  std::string target() const { return kind == "unix" ? "unix:" + address : address; }

  bool operator==(const ListenAddress&) const = default;
};

}  // namespace rbdgrad::server
