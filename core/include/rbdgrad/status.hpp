// Errors as values: every library entry point that can fail returns a Status (or fills one).
// Library code never throws across its public API, never exits and never aborts.
#pragma once

#include <string>
#include <utility>

namespace rbdgrad {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,   // bad input: wrong length, NaN/Inf, unknown name
  kFailedPrecondition,  // the model or state makes the computation impossible (singular M)
  kOutOfRange,        // fixed-point overflow or a value outside what a precision represents
  kNotFound,          // a file or a named item does not exist
  kUnimplemented,     // a feature that is not supported (yet)
  kUnavailable,       // a backend or device that is missing, failed to load or is not ready
  kInternal,          // a bug
  kDeadlineExceeded,  // a request that cannot finish (or did not start) before its deadline
};

const char* status_code_name(StatusCode code) noexcept;

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok() { return {}; }
  bool is_ok() const noexcept { return code_ == StatusCode::kOk; }
  explicit operator bool() const noexcept { return is_ok(); }
  StatusCode code() const noexcept { return code_; }
  const std::string& message() const noexcept { return message_; }
  // "invalid_argument: state 3: field 'q' element 2 is not finite"
  std::string to_string() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status invalid_argument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status failed_precondition(std::string m) { return {StatusCode::kFailedPrecondition, std::move(m)}; }
inline Status out_of_range(std::string m) { return {StatusCode::kOutOfRange, std::move(m)}; }
inline Status not_found(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status unimplemented(std::string m) { return {StatusCode::kUnimplemented, std::move(m)}; }
inline Status unavailable(std::string m) { return {StatusCode::kUnavailable, std::move(m)}; }
inline Status deadline_exceeded(std::string m) { return {StatusCode::kDeadlineExceeded, std::move(m)}; }

}  // namespace rbdgrad
