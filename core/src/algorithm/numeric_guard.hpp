// Turns silent numerical failure into a Status (private header): fixed-point overflow during a call,
// NaN or Inf in floating-point outputs.
#pragma once

#include <cmath>
#include <string>

#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/spatial.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::detail {

template <class S>
class NumericGuard {
 public:
  // `what` names the algorithm in messages.
  explicit NumericGuard(const char* what) : what_(what) {}

  // Checks the outputs when the call is done.
  template <class... Outputs>
  Status finish(const Outputs&... outputs) const {
    if constexpr (is_fixed_point_v<S>) {
      if (scope_.overflowed())
        return out_of_range(std::string(what_) + ": fixed-point overflow (" + std::to_string(scope_.count()) +
                            " saturated operations): values exceed the range of the fixed-point format");
      return Status::ok();
    } else {
      // a NaN or Inf anywhere makes the sum non-finite; cheaper than a per-element test
      using std::isfinite;
      if (!(isfinite(outputs.sum()) && ...))
        return out_of_range(std::string(what_) + ": result is not finite (NaN or Inf)");
      return Status::ok();
    }
  }

 private:
  const char* what_;
  FixedOverflowScope scope_;
};

}  // namespace rbdgrad::detail
