// The outcome of a call to the rbdgrad service: a gRPC status code and the server's message, as a
// value (RpcStatus, returned by the non-throwing calls) or an exception (ClientError, thrown by the
// others). No gRPC type appears here.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

#include "rbdgrad/client_export.hpp"

namespace rbdgrad {

// gRPC's status codes, same numbers (grpc::StatusCode).
enum class RpcCode : int {
  kOk = 0,
  kCancelled = 1,
  kUnknown = 2,
  kInvalidArgument = 3,     // the server refused the request: sizes, NaN/Inf, N = 0, bad option
  kDeadlineExceeded = 4,    // the call's timeout passed
  kNotFound = 5,            // unknown model
  kAlreadyExists = 6,
  kPermissionDenied = 7,
  kResourceExhausted = 8,   // the server is at its limit of requests in flight, or a message is too big
  kFailedPrecondition = 9,  // e.g. singular M; or the client was misused (a closed session)
  kAborted = 10,
  kOutOfRange = 11,         // e.g. fixed-point overflow
  kUnimplemented = 12,
  kInternal = 13,           // a bug, or a response the client could not read
  kUnavailable = 14,        // no server at the address, or the backend is not available
  kDataLoss = 15,
  kUnauthenticated = 16,
};

// "OK", "INVALID_ARGUMENT", "UNAVAILABLE", ... (gRPC's spelling); "UNKNOWN_CODE" for other numbers.
RBDGRAD_CLIENT_EXPORT const char* rpc_code_name(RpcCode code) noexcept;

class RBDGRAD_CLIENT_EXPORT RpcStatus {
 public:
  RpcStatus() = default;
  RpcStatus(RpcCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static RpcStatus ok() { return {}; }
  bool is_ok() const noexcept { return code_ == RpcCode::kOk; }
  explicit operator bool() const noexcept { return is_ok(); }
  RpcCode code() const noexcept { return code_; }
  // The server's message (or, for an error found in the client, one starting with "client: ").
  const std::string& message() const noexcept { return message_; }
  // "INVALID_ARGUMENT: request 'r7': state 3: field 'q' element 2 is not finite (nan)"; "OK".
  std::string to_string() const;

 private:
  RpcCode code_ = RpcCode::kOk;
  std::string message_;
};

// Thrown by the throwing calls; what() is RpcStatus::to_string().
class RBDGRAD_CLIENT_EXPORT ClientError : public std::runtime_error {
 public:
  explicit ClientError(RpcStatus status);
  const RpcStatus& status() const noexcept { return status_; }
  RpcCode code() const noexcept { return status_.code(); }
  const std::string& message() const noexcept { return status_.message(); }

 private:
  RpcStatus status_;
};

}  // namespace rbdgrad
