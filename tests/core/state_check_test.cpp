// Tests for core/src/state_check.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rbdgrad/state_check.hpp"

namespace rbdgrad {
namespace {

TEST(StateCheck, AcceptsAFiniteVectorOfTheRightLength) {
  const double q[3] = {0.1, -2, 3};
  EXPECT_TRUE(check_state_field(0, "q", q, 3, 3).is_ok());
}

TEST(StateCheck, NamesStateFieldAndLengthForAWrongLength) {
  const double q[2] = {0, 0};
  const Status s = check_state_field(4, "qd", q, 2, 7);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "state 4: field 'qd' has 2 values, expected 7");
}

TEST(StateCheck, NamesStateFieldAndElementForNaNAndInf) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double a[3] = {0, nan, 0}, b[3] = {0, 0, -inf};
  EXPECT_EQ(check_state_field(2, "tau", a, 3, 3).message(), "state 2: field 'tau' element 1 is not finite (nan)");
  EXPECT_EQ(check_state_field(9, "q", b, 3, 3).message(), "state 9: field 'q' element 2 is not finite (-inf)");
}

}  // namespace
}  // namespace rbdgrad
