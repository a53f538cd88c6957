// Inside Client: the channel and stub every call shares, and the deadline rules. Private to the
// client library.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>

#include "rbdgrad/client.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad {

struct Client::Impl {
  std::string address;
  ClientOptions options;
  std::shared_ptr<grpc::Channel> channel;        // one connection for every thread
  std::unique_ptr<v1::Dynamics::Stub> stub;      // thread-safe

  // A call's timeout: its own, else the client's default.
  std::chrono::nanoseconds timeout_or_default(std::optional<std::chrono::nanoseconds> timeout) const {
    return timeout.value_or(options.default_timeout);
  }
  // Sets the call's deadline and wait-for-ready.
  void prepare(grpc::ClientContext& ctx, std::optional<std::chrono::nanoseconds> timeout) const;
};

namespace detail {
// now + timeout on the clock gRPC takes; a timeout beyond a year is taken as a year (no overflow)
std::chrono::system_clock::time_point deadline_after(std::chrono::nanoseconds timeout);
}  // namespace detail

}  // namespace rbdgrad
