// The plugin side of rbdgrad_error: the opaque error object of the C ABI, its three table functions,
// the one place where a core Status becomes an ABI error code, and the wrapper that keeps C++
// exceptions from crossing the C boundary (plugin_api.h: "plugins catch everything").
#pragma once

#include <cstdint>
#include <exception>
#include <new>
#include <string>
#include <type_traits>
#include <utility>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

// Completes the ABI's opaque type. Each plugin links its own copy (hidden symbols), so an error must
// go back to the error_delete of the table that produced it, as the ABI says.
struct rbdgrad_error {
  rbdgrad_error_code code;
  std::string message;
};

namespace rbdgrad::plugin {

/// A new error owned by the caller (released with error_delete). Never throws and never returns
/// NULL: when the allocation itself fails it returns a static "out of memory" error, which
/// error_delete recognises and does not free.
rbdgrad_error* make_error(rbdgrad_error_code code, std::string message) noexcept;

/// Same with the message `prefix` + `detail`, built inside (for catch blocks, where building a
/// std::string argument could itself throw).
rbdgrad_error* make_error(rbdgrad_error_code code, const char* prefix, const char* detail) noexcept;

/// invalid_argument -> INVALID_ARGUMENT; out_of_range, failed_precondition -> NUMERICAL;
/// unimplemented -> UNSUPPORTED; anything else -> INTERNAL.
rbdgrad_error_code error_code_from_status(StatusCode code) noexcept;

/// The state_status code of a state that failed with `code` in a batch of `precision`: out_of_range
/// in fixed point means the state left the format's range, RBDGRAD_ERROR_OUT_OF_RANGE, for hosts
/// of API minor >= 1 (older ones get NUMERICAL); otherwise error_code_from_status.
rbdgrad_error_code state_error_code(StatusCode code, std::uint32_t precision) noexcept;

/// NULL for an ok status, else a new error with the status message (no code-name prefix).
rbdgrad_error* make_error(const Status& status) noexcept;

// the three table entries; NULL gives code 0 and message "" (0 is "no error" as in state_status)
uint32_t error_code(const rbdgrad_error* error) noexcept;
const char* error_message(const rbdgrad_error* error) noexcept;
void error_delete(rbdgrad_error* error) noexcept;

namespace detail {
// The INTERNAL error an entry point returns for an exception; nothing for a void entry point.
template <class R>
auto internal_error(const char* prefix, const char* what) noexcept {
  if constexpr (std::is_void_v<R>) return;
  else return make_error(RBDGRAD_ERROR_INTERNAL, prefix, what);
}
}  // namespace detail

/// Runs an entry point body `fn` (returning rbdgrad_error*, a Status, or void) and turns any
/// exception into an INTERNAL error (bad_alloc into "out of memory"), so nothing unwinds into C.
/// For a void body the error is dropped: destroy_instance has no way to report it.
template <class F>
auto guarded(F&& fn) noexcept {
  using R = decltype(fn());
  static_assert(std::is_same_v<R, rbdgrad_error*> || std::is_same_v<R, Status> || std::is_void_v<R>,
                "an entry point body returns rbdgrad_error*, Status or void");
  try {
    if constexpr (std::is_same_v<R, Status>) return make_error(fn());
    else return fn();
  } catch (const std::bad_alloc&) {
    return detail::internal_error<R>("out of memory", "");
  } catch (const std::exception& e) {
    return detail::internal_error<R>("unexpected exception: ", e.what());
  } catch (...) {
    return detail::internal_error<R>("unexpected exception of unknown type", "");
  }
}

}  // namespace rbdgrad::plugin
