// RpcStatus and ClientError: gRPC's status codes by name.
#include "rbdgrad/rpc_status.hpp"

#include <iterator>

namespace rbdgrad {

const char* rpc_code_name(RpcCode code) noexcept {
  // gRPC's own spelling, indexed by code number
  static constexpr const char* kNames[] = {
      "OK",           "CANCELLED",          "UNKNOWN",   "INVALID_ARGUMENT", "DEADLINE_EXCEEDED", "NOT_FOUND",
      "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION", "ABORTED",
      "OUT_OF_RANGE", "UNIMPLEMENTED",      "INTERNAL",  "UNAVAILABLE",      "DATA_LOSS",         "UNAUTHENTICATED"};
  const int i = static_cast<int>(code);
  if (i >= 0 && i < static_cast<int>(std::size(kNames))) return kNames[i];
  return "UNKNOWN_CODE";
}

std::string RpcStatus::to_string() const {
  if (is_ok()) return "OK";
  return std::string(rpc_code_name(code_)) + ": " + message_;
}

ClientError::ClientError(RpcStatus status) : std::runtime_error(status.to_string()), status_(std::move(status)) {}

}  // namespace rbdgrad
