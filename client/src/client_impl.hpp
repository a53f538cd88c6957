// Inside Client: the channel and stub every call shares, and the deadline rules. Private to the
// client library.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>

#include "rbdgrad/client.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad {

struct Client::Impl {
  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  // Waits until no asynchronous call holds the channel any more: the last reference to a channel
  // must not be dropped on one of its own callback threads (gRPC aborts).
  ~Impl();

  std::string address;
  ClientOptions options;
  std::string authorization;  // "Bearer <token>", or "" for none
  std::shared_ptr<grpc::Channel> channel;        // one connection for every thread
  std::unique_ptr<v1::Dynamics::Stub> stub;      // thread-safe

  // asynchronous calls whose gRPC objects (and so channel references) still exist
  std::mutex async_mutex;
  std::condition_variable async_released;
  std::size_t async_in_flight = 0;
  void async_started();
  // after the call's gRPC objects are gone; the Impl may be destroyed as soon as this returns
  void async_finished();

  // A call's timeout: its own, else the client's default.
  std::chrono::nanoseconds timeout_or_default(std::optional<std::chrono::nanoseconds> timeout) const {
    return timeout.value_or(options.default_timeout);
  }
  // Sets the call's deadline and wait-for-ready, and adds the bearer token.
  void prepare(grpc::ClientContext& ctx, std::optional<std::chrono::nanoseconds> timeout) const;
  // The same with the deadline given: every attempt of a retried call shares the first one's.
  void prepare_until(grpc::ClientContext& ctx, std::chrono::system_clock::time_point deadline) const;

  // After attempt number `attempts_made` of a call failed with `code`: the pause before the next
  // attempt, or nullopt when there is none (another code, attempts used up, or the pause would
  // end past `deadline`). Counts the retry, or the call given up on UNAVAILABLE.
  std::optional<std::chrono::nanoseconds> retry_delay(int code, int attempts_made,
                                                      std::chrono::system_clock::time_point deadline) const;
  mutable std::atomic<std::uint64_t> retries{0};
  mutable std::atomic<std::uint64_t> gave_up{0};
  // Adds the bearer token, if any ("authorization: Bearer ..."): plain metadata rather than call
  // credentials, which gRPC sends only over TLS, and a token is also for the loopback and Unix socket.
  void add_token(grpc::ClientContext& ctx) const;
};

namespace detail {
// now + timeout on the clock gRPC takes; a timeout beyond a year is taken as a year (no overflow)
std::chrono::system_clock::time_point deadline_after(std::chrono::nanoseconds timeout);
// The gRPC target for a list of addresses (see Client(const std::vector<std::string>&)); throws
// ClientError (INVALID_ARGUMENT).
std::string target_of(const std::vector<std::string>& addresses);
}  // namespace detail

}  // namespace rbdgrad
