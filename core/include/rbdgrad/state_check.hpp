// Validation of one input state before it reaches an algorithm: the algorithms trust sizes and,
// for speed, do not look at their inputs. Messages name the state and the field.
#pragma once

#include <cstddef>
#include <string>

#include "rbdgrad/status.hpp"

namespace rbdgrad {

/// Checks that `field` of state `state_index` has `expected` values and that all are finite.
/// \return invalid_argument "state 3: field 'qd' has 6 values, expected 7" or
///         "state 3: field 'q' element 2 is not finite (nan)"; ok otherwise.
Status check_state_field(long state_index, const char* field, const double* values, std::size_t size,
                         std::size_t expected);

}  // namespace rbdgrad
