// The service's one conversion from rbdgrad::Status (errors as values inside the daemon) to
// grpc::Status (what a client sees). Every handler goes through here, so that a core code means
// the same gRPC code on every RPC.
#pragma once

#include <grpcpp/support/status.h>

#include "rbdgrad/status.hpp"
#include "scene_registrar.hpp"

namespace rbdgrad::server {

/// ok -> OK, invalid_argument -> INVALID_ARGUMENT, not_found -> NOT_FOUND,
/// failed_precondition -> FAILED_PRECONDITION, out_of_range -> OUT_OF_RANGE,
/// unimplemented -> UNIMPLEMENTED, unavailable -> UNAVAILABLE, internal (and any code this
/// function does not know) -> INTERNAL.
grpc::StatusCode to_grpc_code(StatusCode code) noexcept;

/// The gRPC status with the mapped code and the message unchanged.
grpc::Status to_grpc_status(const Status& status);

/// RegisterScene's answer: OK when registered (now or before, the same definition), ALREADY_EXISTS
/// for a name taken, RESOURCE_EXHAUSTED past limits.max_registered_scenes (codes core's Status
/// does not have), else the refusal's status mapped as above; the message unchanged.
grpc::Status to_grpc_status(const SceneRegistration& registration);

}  // namespace rbdgrad::server
