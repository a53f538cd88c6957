// rbdgrad::Status -> grpc::Status, the one mapping of error codes at the service's edge.
#include "grpc_status.hpp"

namespace rbdgrad::server {

grpc::StatusCode to_grpc_code(StatusCode code) noexcept {
  switch (code) {
    case StatusCode::kOk: return grpc::StatusCode::OK;
    case StatusCode::kInvalidArgument: return grpc::StatusCode::INVALID_ARGUMENT;
    case StatusCode::kNotFound: return grpc::StatusCode::NOT_FOUND;
    case StatusCode::kFailedPrecondition: return grpc::StatusCode::FAILED_PRECONDITION;
    case StatusCode::kOutOfRange: return grpc::StatusCode::OUT_OF_RANGE;
    case StatusCode::kUnimplemented: return grpc::StatusCode::UNIMPLEMENTED;
    case StatusCode::kUnavailable: return grpc::StatusCode::UNAVAILABLE;
    case StatusCode::kInternal: return grpc::StatusCode::INTERNAL;
    case StatusCode::kDeadlineExceeded: return grpc::StatusCode::DEADLINE_EXCEEDED;
  }
  // a code added to core without a mapping here is a bug of ours, not of the client's request
  return grpc::StatusCode::INTERNAL;
}

grpc::Status to_grpc_status(const Status& status) {
  if (status.is_ok()) return grpc::Status::OK;
  return {to_grpc_code(status.code()), status.message()};
}

grpc::Status to_grpc_status(const SceneRegistration& registration) {
  switch (registration.outcome) {
    case RegistrationOutcome::kRegistered:
    case RegistrationOutcome::kAlreadyRegistered: return grpc::Status::OK;
    case RegistrationOutcome::kNameTaken:
      return {grpc::StatusCode::ALREADY_EXISTS, registration.status.message()};
    case RegistrationOutcome::kLimitReached:
      return {grpc::StatusCode::RESOURCE_EXHAUSTED, registration.status.message()};
    case RegistrationOutcome::kRefused: break;
  }
  return to_grpc_status(registration.status);
}

}  // namespace rbdgrad::server
