// The client's edge to the wire: ComputeRequest into the proto message, proto enums to and from
// the API's enums, grpc::Status into RpcStatus. Private to the client library.
#pragma once

#include <cstdint>

#include <grpcpp/support/status.h>

#include "rbdgrad/compute_types.hpp"
#include "rbdgrad/rpc_status.hpp"
#include "rbdgrad/service_info.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::detail {

// What a response must hold, derived from the request that asked for it.
struct ExpectedResult {
  std::uint32_t num_states = 0;
  int nv = -1;                // q.size() / num_states; -1 when that does not divide
  std::uint32_t outputs = 0;  // Output bits
  ScalarType type = ScalarType::kF64;
};

ExpectedResult expected_result(const ComputeRequest& req) noexcept;

/// Fills `msg` from `req`, reusing the message's buffers (one copy per array). Only checks what
/// cannot be sent at all: output bits that name no output.
/// \return ok, or INVALID_ARGUMENT "client: ..." (then nothing should be sent).
RpcStatus encode_request(const ComputeRequest& req, v1::ComputeRequest& msg);

/// Fills `msg` from `scene`. Only checks what cannot be sent: output bits that name no output.
/// \return ok, or INVALID_ARGUMENT "client: ..." (then nothing should be sent).
RpcStatus encode_scene_definition(const SceneDefinition& scene, v1::RegisterSceneRequest& msg);

RpcStatus from_grpc(const grpc::Status& status);

v1::Precision to_proto(Precision p) noexcept;
v1::Backend to_proto(Backend b) noexcept;
Precision from_proto(v1::Precision p) noexcept;
Backend from_proto(v1::Backend b) noexcept;  // kAuto for a value this client does not know

// the proto's Output numbering is not the bit order
v1::Output output_to_proto(Output o) noexcept;

}  // namespace rbdgrad::detail
