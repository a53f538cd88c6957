// What service_load sends: seeded random states of a model packed into ComputeRequests (one per N,
// built once and reused for every call), the size of the matching ComputeResponse, and the
// EchoRequest that moves the same number of bytes each way.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "echo.pb.h"
#include "load_options.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::bench {

// `count` random states drawn once (std::mt19937 with a fixed seed), so every tool invocation with
// the same seed and model sends the same numbers: q uniform within the joint limits (+-pi where
// the URDF gives none), qd within +-2 (rad or m)/s, u within +-effort limit (+-10 without one) as
// tau, or within +-5 as qdd. Arrays are count x nv, state-major.
struct StatePool {
  int nv = 0;
  std::vector<double> q, qd, u;
};
StatePool make_state_pool(const Model& model, std::size_t count, v1::InputKind input_kind, std::uint32_t seed);

/// The request for the first `n` states of `pool` (n <= pool size), with the options' outputs,
/// precision and input kind; f64 tensors, outputs requested as f64, backend AUTO, no request id.
v1::ComputeRequest make_compute_request(const StatePool& pool, std::uint32_t n, const LoadOptions& options);

/// Serialised size of the response the server sends for `request` (model with `nv` joints): the
/// requested outputs as f64 tensors, num_states, backend, precision and timings. The timings' varints
/// are estimated (2-3 bytes each), so the figure may differ from a real response by a few bytes.
std::size_t expected_response_bytes(const v1::ComputeRequest& request, int nv);

/// An EchoRequest whose serialised size is `request_bytes` and whose response_bytes makes the
/// EchoResponse serialise to `response_bytes` (exact, or one byte off where varint lengths make
/// the exact size impossible).
EchoRequest make_echo_request(std::size_t request_bytes, std::size_t response_bytes);

}  // namespace rbdgrad::bench
