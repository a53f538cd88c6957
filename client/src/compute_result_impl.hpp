// Inside ComputeResult: the received response message and the checked views onto its bytes.
// Private to the client library.
#pragma once

#include <array>
#include <cstdint>

#include "rbdgrad/compute_result.hpp"
#include "rbdgrad/rpc_status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"
#include "request_encoding.hpp"

namespace rbdgrad {

struct ComputeResult::Impl {
  v1::ComputeResponse response;  // owns the bytes every view points into; reused by the next call
  bool valid = false;
  int nv = 0;
  std::uint32_t outputs = 0;     // Output bits present
  ScalarType type = ScalarType::kF64;
  Backend backend = Backend::kAuto;
  Precision precision = Precision::kAuto;
  ComputeTimings timings;
  std::array<const unsigned char*, 8> data{};  // first byte of each output, by bit index
};

namespace detail {

struct ResultAccess {
  // The result's Impl, created on first use (a default ComputeResult holds none); marked invalid
  // until adopt_response succeeds.
  static ComputeResult::Impl& reset_for_call(ComputeResult& r);
  static void invalidate(ComputeResult& r) noexcept;
};

/// Checks `impl.response` against what the request asked for (N, nv, outputs, their encoding)
/// and, when it matches, fills the views and marks the result valid.
/// \return ok, or INTERNAL "client: malformed response ..." naming the output and the sizes.
RpcStatus adopt_response(const ExpectedResult& expected, ComputeResult::Impl& impl, double round_trip_us);

}  // namespace detail
}  // namespace rbdgrad
