#include "rbdgrad/state_check.hpp"

#include <cmath>

namespace rbdgrad {

Status check_state_field(long state_index, const char* field, const double* values, std::size_t size,
                         std::size_t expected) {
  const std::string where = "state " + std::to_string(state_index) + ": field '" + field + "'";
  if (size != expected)
    return invalid_argument(where + " has " + std::to_string(size) + " values, expected " + std::to_string(expected));
  for (std::size_t k = 0; k < size; ++k) {
    if (!std::isfinite(values[k]))
      return invalid_argument(where + " element " + std::to_string(k) + " is not finite (" +
                              (std::isnan(values[k]) ? "nan" : values[k] > 0 ? "inf" : "-inf") + ")");
  }
  return Status::ok();
}

}  // namespace rbdgrad
