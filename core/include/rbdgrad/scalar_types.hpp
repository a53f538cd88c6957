// The scalar types every algorithm is compiled for: f64, f32 and 32-bit fixed point (Q16.16).
#pragma once

#include "rbdgrad/fixed_point.hpp"

// Explicitly instantiates MACRO(T) for each served scalar type.
#define RBDGRAD_FOR_EACH_SCALAR(MACRO) \
  MACRO(double)                        \
  MACRO(float)                         \
  MACRO(::rbdgrad::Q16_16)

// Also compiled for the core algorithms in core/src (never served, so not in the list above and
// not seen by the plugins): long double (64-bit mantissa on x86) is the higher-precision reference
// the stability tests measure f64 against (tests/stability, bench/stability).
#define RBDGRAD_FOR_EACH_REFERENCE_SCALAR(MACRO) MACRO(long double)
