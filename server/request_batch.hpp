// One ComputeRequest as a plugin batch: validates the request's tensors and converts them into
// typed buffers in the compute precision, then copies the outputs back into a ComputeResponse.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::server {

// The rbdgrad_output bit for a proto Output; 0 for OUTPUT_UNSPECIFIED and unknown values.
uint32_t output_flag(rbdgrad::v1::Output output) noexcept;
/// The inverse: RBDGRAD_OUTPUT_DQDD_DQ -> OUTPUT_DQDD_DQ; OUTPUT_UNSPECIFIED for anything but one flag.
rbdgrad::v1::Output output_enum(uint32_t flag) noexcept;
// The response's tensor of a proto Output; nullptr for OUTPUT_UNSPECIFIED and unknown values.
rbdgrad::v1::Tensor* response_tensor(rbdgrad::v1::ComputeResponse& response, rbdgrad::v1::Output output);
// Whether an output is nv x nv per state (else nv).
bool is_matrix_output(rbdgrad::v1::Output output) noexcept;

class RequestBatch {
 public:
  RequestBatch() = default;
  // batch_ points into the buffers below: a copy would alias them, a move keeps them valid
  // (std::vector's move hands over its heap block).
  RequestBatch(const RequestBatch&) = delete;
  RequestBatch& operator=(const RequestBatch&) = delete;
  RequestBatch(RequestBatch&&) noexcept = default;
  RequestBatch& operator=(RequestBatch&&) noexcept = default;

  /// Validates `req` for a model with `nv` joints and converts its inputs into `precision`
  /// (F64, F32 or FIXED_Q16_16; AUTO must be resolved by the caller). Allocates the buffers of
  /// the requested outputs only and a state_status of num_states entries. On error `out` is
  /// left untouched and the Status is invalid_argument naming the request id, the field and,
  /// for a bad value, the state and element.
  /// With `direct`, when the computation and the wire are both F64 the backend writes the outputs
  /// straight into direct's tensors (sized and typed here; no copy in to_response): `direct` must
  /// then outlive the computation and be the response given to to_response.
  static Status from_request(const rbdgrad::v1::ComputeRequest& req, int nv, rbdgrad_precision precision,
                             uint32_t max_states, RequestBatch& out, rbdgrad::v1::ComputeResponse* direct = nullptr);

  /// The batch to hand to a plugin's compute; its pointers stay valid while *this lives.
  const rbdgrad_batch& batch() const noexcept { return batch_; }
  rbdgrad_batch& mutable_batch() noexcept { return batch_; }

  /// Copies every requested output into `resp` encoded as `output_type` (UNSPECIFIED = F64;
  /// Q16.16 values become raw / 65536), with request_id, num_states and precision. Outputs that
  /// from_request pointed at `direct` are already in place and not copied.
  void to_response(rbdgrad::v1::ComputeResponse& resp, rbdgrad::v1::ScalarType output_type) const;

  int nv() const noexcept { return nv_; }
  uint64_t num_states() const noexcept { return batch_.n; }

 private:
  // one field's scalars in the compute precision (8, 4 or 4 bytes each); std::byte storage so
  // one type serves all three precisions; new[] alignment (16) suffices for double
  using Buffer = std::vector<std::byte>;

  int nv_ = 0;
  std::string request_id_;
  rbdgrad_batch batch_{};
  Buffer q_, qd_, u_, minv_, fext_;
  Buffer qdd_, minv_out_, dqdd_dq_, dqdd_dqd_, tau_, dtau_dq_, dtau_dqd_, m_;
  std::vector<int32_t> state_status_;
  uint32_t direct_outputs_ = 0;  // rbdgrad_output flags written straight into the response
};

}  // namespace rbdgrad::server
