#include "error.hpp"

#include "host_api.hpp"

namespace rbdgrad::plugin {

namespace {

// Returned when even the error cannot be allocated; never freed.
rbdgrad_error* out_of_memory_error() noexcept {
  static rbdgrad_error error{RBDGRAD_ERROR_INTERNAL, "out of memory"};  // short: no allocation (SSO)
  return &error;
}

}  // namespace

rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) noexcept {
  try {
    return new rbdgrad_error{code, std::move(message)};
  } catch (...) {
    return out_of_memory_error();
  }
}

rbdgrad_error* make_error(rbdgrad_error_code code, const char* prefix, const char* detail) noexcept {
  try {
    std::string message(prefix ? prefix : "");
    message += detail ? detail : "";
    return new rbdgrad_error{code, std::move(message)};
  } catch (...) {
    return out_of_memory_error();
  }
}

rbdgrad_error_code error_code_from_status(StatusCode code) noexcept {
  switch (code) {
    case StatusCode::kInvalidArgument: return RBDGRAD_ERROR_INVALID_ARGUMENT;
    case StatusCode::kOutOfRange:
    case StatusCode::kFailedPrecondition: return RBDGRAD_ERROR_NUMERICAL;
    case StatusCode::kUnimplemented: return RBDGRAD_ERROR_UNSUPPORTED;
    case StatusCode::kUnavailable: return RBDGRAD_ERROR_UNAVAILABLE;
    default: return RBDGRAD_ERROR_INTERNAL;
  }
}

rbdgrad_error_code state_error_code(StatusCode code, std::uint32_t precision) noexcept {
  if (code == StatusCode::kOutOfRange && precision == RBDGRAD_PRECISION_FIXED_Q16_16 && host_api_minor() >= 1) {
    return RBDGRAD_ERROR_OUT_OF_RANGE;
  }
  return error_code_from_status(code);
}

rbdgrad_error* make_error(const Status& status) noexcept {
  if (status.is_ok()) return nullptr;
  // an ok-looking message would hide the problem: say which core code came without one
  if (status.message().empty())
    return make_error(error_code_from_status(status.code()), "error without a message: ",
                      status_code_name(status.code()));
  return make_error(error_code_from_status(status.code()), status.message().c_str(), "");
}

uint32_t error_code(const rbdgrad_error* error) noexcept {
  return error ? error->code : static_cast<rbdgrad_error_code>(0);
}

const char* error_message(const rbdgrad_error* error) noexcept { return error ? error->message.c_str() : ""; }

void error_delete(rbdgrad_error* error) noexcept {
  if (error != out_of_memory_error()) delete error;
}

}  // namespace rbdgrad::plugin
