// The proto's enums (rbdgrad.v1 Backend, Precision) against the names and flags the daemon uses
// inside: backend names ("cpu") and rbdgrad_precision flags.
#pragma once

#include <cstdint>
#include <string_view>

#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::server {

/// BACKEND_CPU -> "cpu", BACKEND_CUDA -> "cuda", BACKEND_FPGA -> "fpga", BACKEND_AUTO -> "".
/// False for a value the proto does not define.
bool backend_name(int backend, std::string_view& out) noexcept;

/// The inverse: "cpu" -> BACKEND_CPU, ...; BACKEND_AUTO for any other name (a backend the proto
/// has no value for).
rbdgrad::v1::Backend backend_enum(std::string_view name) noexcept;

/// PRECISION_F64 -> RBDGRAD_PRECISION_F64, ..., PRECISION_AUTO -> 0. False for an unknown value.
bool precision_flag(int precision, std::uint32_t& out) noexcept;

/// RBDGRAD_PRECISION_F64 -> PRECISION_F64, ...; PRECISION_AUTO for anything else.
rbdgrad::v1::Precision precision_enum(std::uint32_t flag) noexcept;

}  // namespace rbdgrad::server
