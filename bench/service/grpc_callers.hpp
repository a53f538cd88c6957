// One caller of service_load: a connection's worth of calls to the Dynamics or the Echo service,
// unary (a fresh ClientContext per call, as gRPC requires) or over one long-lived bidirectional
// stream (write a request, read its response). The load loop times call() and runs check() after it.
#pragma once

#include <functional>
#include <memory>

#include <grpcpp/grpcpp.h>

#include "echo.grpc.pb.h"
#include "load_options.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad::bench {

// What the server reports it spent on one request (ComputeResponse.timings), microseconds.
struct ServerTimings {
  double queue_us = 0, compute_us = 0, total_us = 0;
};

class Caller {
 public:
  virtual ~Caller() = default;
  /// One round trip: send the request, wait for the response. Not thread-safe; one thread per caller.
  virtual Status call() = 0;
  /// Checks the last response (response_check.hpp); not timed.
  virtual Status check() const = 0;
  /// Ends the call sequence: a stream is half-closed and its final status read. Idempotent.
  virtual Status finish() = 0;
  /// The server's own timings of the last response, when its message carries them (Dynamics).
  virtual bool server_timings(ServerTimings& out) const = 0;
};

// checks one response of type R; returns ok or why it is wrong
template <class R>
using ResponseCheck = std::function<Status(const R&)>;

/// A channel to `target` with no message size limits (the large payloads exceed gRPC's 4 MiB default).
std::shared_ptr<grpc::Channel> make_channel(const std::string& target);

/// Waits up to `timeout_s` for the channel to connect; unavailable naming the target otherwise.
Status wait_connected(grpc::Channel& channel, const std::string& target, double timeout_s);

/// Callers of Dynamics.Compute / ComputeStream sending `request` (which must outlive the caller).
std::unique_ptr<Caller> make_dynamics_caller(v1::Dynamics::Stub& stub, CallMode mode, const v1::ComputeRequest& request,
                                             ResponseCheck<v1::ComputeResponse> check);

/// Callers of Echo.Unary / Echo.Stream sending `request` (which must outlive the caller).
std::unique_ptr<Caller> make_echo_caller(Echo::Stub& stub, CallMode mode, const EchoRequest& request,
                                         ResponseCheck<EchoResponse> check);

}  // namespace rbdgrad::bench
