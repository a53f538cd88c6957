// Checks of the responses service_load receives, run after every call outside the timed region,
// so that a server that answers fast but wrongly (an error, missing or short outputs, NaN, other
// numbers than the in-process computation) fails the benchmark instead of looking fast.
#pragma once

#include "echo.pb.h"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::bench {

/// A Dynamics response to `request` (model with `nv` joints): num_states equal to the request's;
/// every requested output an f64 tensor of num_states x nv (x nv for matrices) values, all finite;
/// no output that was not requested. With `reference` (the same request computed in-process), every
/// value within `tolerance` relative to its state's block: |a - b| <= tol * max(1, max |b| over
/// that state's vector or matrix), the convention of the accuracy tests (an element near zero in
/// a large matrix differs between backends by the matrix's rounding, not its own).
/// Errors (invalid_argument) name N, the field and, for a value, the state and element.
Status check_compute_response(const v1::ComputeRequest& request, int nv, const v1::ComputeResponse& response,
                              const v1::ComputeResponse* reference, double tolerance);

/// An Echo response: exactly request.response_bytes() payload bytes.
Status check_echo_response(const EchoRequest& request, const EchoResponse& response);

}  // namespace rbdgrad::bench
