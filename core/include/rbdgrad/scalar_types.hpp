// The scalar types every algorithm is compiled for: f64, f32 and 32-bit fixed point (Q16.16).
#pragma once

#include "rbdgrad/fixed_point.hpp"

// Explicitly instantiates MACRO(T) for each served scalar type.
#define RBDGRAD_FOR_EACH_SCALAR(MACRO) \
  MACRO(double)                        \
  MACRO(float)                         \
  MACRO(::rbdgrad::Q16_16)
