// Tests for core/include/rbdgrad/fixed_point.hpp.
#include "rbdgrad/fixed_point.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross()

namespace {

using rbdgrad::Fixed;
using rbdgrad::FixedOverflowScope;
using rbdgrad::FixedPointStatus;
using rbdgrad::Q16_16;

constexpr double kLsb = 1.0 / 65536.0;  // one LSB of Q16.16

// Every test starts and (unless it checks otherwise) ends without overflow.
class FixedPointTest : public ::testing::Test {
 protected:
  void SetUp() override { FixedPointStatus::clear(); }
};

// Exact product rounded to nearest, ties away from zero (reference for mul).
std::int64_t reference_mul_raw(std::int64_t a, std::int64_t b, int frac) {
  const std::int64_t p = a * b;
  const std::int64_t half = std::int64_t{1} << (frac - 1);
  return p >= 0 ? (p + half) >> frac : -((-p + half) >> frac);
}

// Templated code calls math the way Eigen does: std overloads + ADL.
template <class S>
S generic_hypot(S a, S b) {
  using std::sqrt;
  return sqrt(a * a + b * b);
}

// ---- compile-time properties ------------------------------------------------

static_assert(sizeof(Fixed<8, 4>) == 1);
static_assert(sizeof(Fixed<16, 8>) == 2);
static_assert(sizeof(Fixed<24, 12>) == 4);
static_assert(sizeof(Q16_16) == 4);
static_assert(std::is_trivially_copyable_v<Q16_16>);
static_assert(Q16_16(1.5).raw() == 98304);
static_assert((Q16_16(1.5) * Q16_16(2)).raw() == 3 * 65536);
static_assert(rbdgrad::is_fixed_point_v<Q16_16>);
static_assert(rbdgrad::is_fixed_point_v<const Fixed<24, 12>>);
static_assert(!rbdgrad::is_fixed_point_v<double>);
static_assert(!rbdgrad::is_fixed_point_v<int>);

TEST_F(FixedPointTest, ConstexprArithmeticAndSqrt) {
  constexpr Q16_16 a(2.25);
  constexpr Q16_16 r = sqrt(a);  // ADL on a hidden friend
  static_assert(r.raw() == 98304);
  constexpr Q16_16 q = Q16_16(1) / Q16_16(4);
  static_assert(q.raw() == 16384);
  EXPECT_EQ(r, 1.5);
  EXPECT_EQ(q, 0.25);
}

// ---- conversions ------------------------------------------------------------

TEST_F(FixedPointTest, RoundTripOfRepresentableValues) {
  for (std::int64_t raw : {std::int64_t{0}, std::int64_t{1}, std::int64_t{-1}, std::int64_t{65536},
                           std::int64_t{-98304}, std::int64_t{123456789},
                           std::int64_t{-123456789}, Q16_16::raw_max, Q16_16::raw_min}) {
    const Q16_16 f = Q16_16::from_raw(raw);
    EXPECT_EQ(f.raw(), raw);
    const double d = f.to_double();
    EXPECT_EQ(d, static_cast<double>(raw) * kLsb);
    EXPECT_EQ(static_cast<double>(f), d);
    EXPECT_EQ(Q16_16(d).raw(), raw) << "raw " << raw;
  }
  EXPECT_EQ(Q16_16(3).raw(), 3 * 65536);
  EXPECT_EQ(Q16_16(-7).raw(), -7 * 65536);
  EXPECT_EQ(Q16_16(0.75f).raw(), 49152);
  EXPECT_EQ(static_cast<float>(Q16_16(-0.75)), -0.75f);
  EXPECT_EQ(Q16_16().raw(), 0);
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, ConversionRoundsToNearest) {
  EXPECT_EQ(Q16_16(1.4 * kLsb).raw(), 1);
  EXPECT_EQ(Q16_16(1.6 * kLsb).raw(), 2);
  EXPECT_EQ(Q16_16(0.5 * kLsb).raw(), 1);  // tie: away from zero
  EXPECT_EQ(Q16_16(0.49 * kLsb).raw(), 0);
  EXPECT_EQ(Q16_16(-1.4 * kLsb).raw(), -1);
  EXPECT_EQ(Q16_16(-1.6 * kLsb).raw(), -2);
  EXPECT_EQ(Q16_16(-0.5 * kLsb).raw(), -1);  // symmetric with the positive tie
  EXPECT_EQ(Q16_16(-2.5 * kLsb).raw(), -3);

  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> dist(-30000.0, 30000.0);
  for (int i = 0; i < 10000; ++i) {
    const double x = dist(rng);
    const Q16_16 f(x);
    EXPECT_LE(std::abs(f.to_double() - x), 0.5 * kLsb) << x;
    EXPECT_EQ(static_cast<double>(f.raw()), std::round(x * 65536.0)) << x;
  }
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, MultiplyRoundsToNearest) {
  const Q16_16 half(0.5);
  EXPECT_EQ((Q16_16::from_raw(3) * half).raw(), 2);    // 1.5 LSB -> 2
  EXPECT_EQ((Q16_16::from_raw(-3) * half).raw(), -2);  // -1.5 LSB -> -2
  EXPECT_EQ((Q16_16::from_raw(5) * Q16_16(0.25)).raw(), 1);    // 1.25 -> 1
  EXPECT_EQ((Q16_16::from_raw(7) * Q16_16(0.25)).raw(), 2);    // 1.75 -> 2
  EXPECT_EQ((Q16_16::from_raw(-7) * Q16_16(0.25)).raw(), -2);  // -1.75 -> -2
  EXPECT_EQ((Q16_16::from_raw(-5) * Q16_16(0.25)).raw(), -1);  // -1.25 -> -1
  EXPECT_EQ((Q16_16(1.5) * Q16_16(-2.0)).raw(), -3 * 65536);

  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> dist(-(std::int64_t{1} << 23),
                                                   std::int64_t{1} << 23);
  for (int i = 0; i < 10000; ++i) {
    const std::int64_t a = dist(rng);
    const std::int64_t b = dist(rng);
    const Q16_16 p = Q16_16::from_raw(a) * Q16_16::from_raw(b);
    ASSERT_EQ(p.raw(), reference_mul_raw(a, b, 16)) << a << " * " << b;
  }
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, DivisionRoundsToNearest) {
  EXPECT_EQ((Q16_16(1) / Q16_16(3)).raw(), 21845);   // 21845.33
  EXPECT_EQ((Q16_16(2) / Q16_16(3)).raw(), 43691);   // 43690.67
  EXPECT_EQ((Q16_16(-2) / Q16_16(3)).raw(), -43691);
  EXPECT_EQ((Q16_16(2) / Q16_16(-3)).raw(), -43691);
  EXPECT_EQ((Q16_16(-2) / Q16_16(-3)).raw(), 43691);
  EXPECT_EQ((Q16_16::from_raw(1) / Q16_16(2)).raw(), 1);    // 0.5 LSB: tie away
  EXPECT_EQ((Q16_16::from_raw(-1) / Q16_16(2)).raw(), -1);
  EXPECT_EQ(Q16_16(10) / 4, 2.5);
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

// ---- saturation and the overflow status -----------------------------------

TEST_F(FixedPointTest, SaturationSetsFlagOnEveryOperation) {
  const Q16_16 max = std::numeric_limits<Q16_16>::max();
  const Q16_16 lowest = std::numeric_limits<Q16_16>::lowest();
  ASSERT_EQ(max.raw(), INT32_MAX);
  ASSERT_EQ(lowest.raw(), INT32_MIN);
  ASSERT_FALSE(FixedPointStatus::overflowed());

  EXPECT_EQ(max + Q16_16::from_raw(1), max);
  EXPECT_EQ(FixedPointStatus::count(), 1u);
  EXPECT_EQ(lowest - Q16_16::from_raw(1), lowest);
  EXPECT_EQ(FixedPointStatus::count(), 2u);
  EXPECT_EQ(Q16_16(30000) - Q16_16(-30000), max);
  EXPECT_EQ(FixedPointStatus::count(), 3u);
  EXPECT_EQ(Q16_16(300) * Q16_16(300), max);
  EXPECT_EQ(Q16_16(300) * Q16_16(-300), lowest);
  EXPECT_EQ(FixedPointStatus::count(), 5u);
  EXPECT_EQ(Q16_16(30000) / Q16_16(0.5), max);
  EXPECT_EQ(Q16_16(-30000) / Q16_16(0.25), lowest);
  EXPECT_EQ(lowest / Q16_16(-1), max);  // the classic INT_MIN / -1
  EXPECT_EQ(FixedPointStatus::count(), 8u);
  EXPECT_EQ(-lowest, max);
  EXPECT_EQ(abs(lowest), max);
  EXPECT_EQ(FixedPointStatus::count(), 10u);

  Q16_16 acc(32767);
  acc += Q16_16(10);
  EXPECT_EQ(acc, max);
  EXPECT_EQ(FixedPointStatus::count(), 11u);
  EXPECT_TRUE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, ConversionSaturatesAndFlags) {
  EXPECT_EQ(Q16_16(1e10).raw(), INT32_MAX);
  EXPECT_EQ(Q16_16(-1e10).raw(), INT32_MIN);
  EXPECT_EQ(Q16_16(std::numeric_limits<double>::infinity()).raw(), INT32_MAX);
  EXPECT_EQ(Q16_16(-std::numeric_limits<double>::infinity()).raw(), INT32_MIN);
  EXPECT_EQ(FixedPointStatus::count(), 4u);
  EXPECT_EQ(Q16_16(std::numeric_limits<double>::quiet_NaN()).raw(), 0);
  EXPECT_EQ(FixedPointStatus::count(), 5u);
  EXPECT_EQ(Q16_16(40000).raw(), INT32_MAX);
  EXPECT_EQ(Q16_16(-40000L).raw(), INT32_MIN);
  EXPECT_EQ(Q16_16(std::uint64_t{1} << 63).raw(), INT32_MAX);
  EXPECT_EQ(FixedPointStatus::count(), 8u);

  // Boundary: half an LSB above max rounds out of range, just below it does not.
  FixedPointStatus::clear();
  const double max_d = std::numeric_limits<Q16_16>::max().to_double();
  EXPECT_EQ(Q16_16(max_d + 0.49 * kLsb).raw(), INT32_MAX);
  EXPECT_EQ(Q16_16(-32768.0).raw(), INT32_MIN);
  EXPECT_EQ(Q16_16(32767).raw(), 32767 * 65536);
  EXPECT_EQ(Q16_16(-32768).raw(), INT32_MIN);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(Q16_16(max_d + 0.5 * kLsb).raw(), INT32_MAX);
  EXPECT_EQ(Q16_16(-32768.0 - 0.5 * kLsb).raw(), INT32_MIN);
  EXPECT_EQ(FixedPointStatus::count(), 2u);
}

TEST_F(FixedPointTest, DivisionByZero) {
  EXPECT_EQ(Q16_16(3) / Q16_16(0), std::numeric_limits<Q16_16>::max());
  EXPECT_EQ(FixedPointStatus::count(), 1u);
  EXPECT_EQ(Q16_16(-3) / Q16_16(0), std::numeric_limits<Q16_16>::lowest());
  EXPECT_EQ(FixedPointStatus::count(), 2u);
  EXPECT_EQ((Q16_16(0) / Q16_16(0)).raw(), 0);
  EXPECT_EQ(FixedPointStatus::count(), 3u);
  Q16_16 x(1);
  x /= 0;
  EXPECT_EQ(x, std::numeric_limits<Q16_16>::max());
  EXPECT_EQ(FixedPointStatus::count(), 4u);
}

TEST_F(FixedPointTest, NoFlagWithoutOverflow) {
  Q16_16 acc(0);
  for (int i = 1; i <= 100; ++i) {
    acc += Q16_16(i) * Q16_16(0.5) - Q16_16(1) / Q16_16(i);
  }
  EXPECT_NEAR(acc.to_double(), 2525.0 - 5.187377517639621, 1e-3);
  EXPECT_EQ(-Q16_16::from_raw(Q16_16::raw_max), Q16_16::from_raw(-Q16_16::raw_max));
  EXPECT_TRUE(Q16_16(1) < 1e10);  // mixed comparison is exact, not a conversion
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(FixedPointStatus::count(), 0u);
}

TEST_F(FixedPointTest, FlagIsStickyUntilCleared) {
  (void)(Q16_16(30000) + Q16_16(30000));
  ASSERT_TRUE(FixedPointStatus::overflowed());
  for (int i = 0; i < 100; ++i) {
    (void)(Q16_16(i) * Q16_16(0.5) + Q16_16(1));
  }
  EXPECT_TRUE(FixedPointStatus::overflowed());
  EXPECT_EQ(FixedPointStatus::count(), 1u);

  FixedOverflowScope scope;  // counts from here without clearing
  EXPECT_FALSE(scope.overflowed());
  (void)(Q16_16(-30000) - Q16_16(30000));
  EXPECT_EQ(scope.count(), 1u);
  EXPECT_EQ(FixedPointStatus::count(), 2u);

  FixedPointStatus::clear();
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(FixedPointStatus::count(), 0u);
}

TEST_F(FixedPointTest, FlagIsPerThread) {
  (void)(Q16_16(30000) * Q16_16(3));
  ASSERT_EQ(FixedPointStatus::count(), 1u);

  bool worker_started_clear = false;
  std::uint64_t worker_count = 0;
  bool worker_cleared = false;
  std::thread worker([&] {
    worker_started_clear = !FixedPointStatus::overflowed();
    (void)(Q16_16(30000) + Q16_16(30000));
    (void)(Q16_16(1) / Q16_16(0));
    worker_count = FixedPointStatus::count();
    FixedPointStatus::clear();
    worker_cleared = !FixedPointStatus::overflowed();
  });
  worker.join();

  EXPECT_TRUE(worker_started_clear);
  EXPECT_EQ(worker_count, 2u);
  EXPECT_TRUE(worker_cleared);
  // The worker's overflows and its clear() did not touch this thread.
  EXPECT_EQ(FixedPointStatus::count(), 1u);
}

// ---- math functions ---------------------------------------------------------

TEST_F(FixedPointTest, SqrtIsCorrectlyRounded) {
  EXPECT_EQ(sqrt(Q16_16(4)), 2.0);
  EXPECT_EQ(sqrt(Q16_16(0)), 0.0);
  EXPECT_EQ(sqrt(Q16_16(0.0625)), 0.25);
  EXPECT_EQ(generic_hypot(Q16_16(3), Q16_16(4)), 5.0);

  std::mt19937_64 rng(3);
  std::uniform_int_distribution<std::int64_t> dist(0, Q16_16::raw_max);
  for (int i = 0; i < 10000; ++i) {
    const Q16_16 x = Q16_16::from_raw(dist(rng));
    const double exact = std::sqrt(x.to_double());
    ASSERT_LE(std::abs(sqrt(x).to_double() - exact), 0.5 * kLsb) << x.raw();
  }
  EXPECT_LE(std::abs(sqrt(std::numeric_limits<Q16_16>::max()).to_double() -
                     std::sqrt(32768.0)),
            0.5 * kLsb);
  EXPECT_FALSE(FixedPointStatus::overflowed());

  EXPECT_EQ(sqrt(Q16_16(-1)), 0.0);
  EXPECT_TRUE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, SinCosWithinOneLsb) {
  for (int i = -2000; i <= 2000; ++i) {
    const Q16_16 a(i * 0.005);
    using std::cos;
    using std::sin;
    const double ad = a.to_double();
    ASSERT_LE(std::abs(sin(a).to_double() - std::sin(ad)), kLsb) << ad;
    ASSERT_LE(std::abs(cos(a).to_double() - std::cos(ad)), kLsb) << ad;
  }
  EXPECT_EQ(cos(Q16_16(0)), 1.0);
  EXPECT_EQ(sin(Q16_16(0)), 0.0);
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, ClassificationAndMinMax) {
  const Q16_16 a(-2.5);
  const Q16_16 b(1.25);
  using std::isfinite;
  using std::max;
  using std::min;
  EXPECT_TRUE(isfinite(a));
  EXPECT_FALSE(isnan(a));
  EXPECT_FALSE(isinf(std::numeric_limits<Q16_16>::max()));
  EXPECT_EQ(min(a, b), a);
  EXPECT_EQ(max(a, b), b);
  EXPECT_EQ(abs(a), 2.5);
  EXPECT_EQ(fabs(a), 2.5);
  EXPECT_EQ(std::max(a, b), b);  // std algorithms work through operator<
}

TEST_F(FixedPointTest, MixedOperandsAndComparisons) {
  const Q16_16 x(1.5);
  EXPECT_EQ(x * 2, 3.0);
  EXPECT_EQ(2.0 * x, 3.0);
  EXPECT_EQ(x + 1, 2.5);
  EXPECT_EQ(1 - x, -0.5);
  EXPECT_EQ(x / 2.0, 0.75);
  EXPECT_TRUE(x > 1);
  EXPECT_TRUE(1.0 < x);
  EXPECT_TRUE(x <= 1.5);
  EXPECT_TRUE(x >= Q16_16(1.5));
  EXPECT_TRUE(x != Q16_16(1.25));
  EXPECT_TRUE(Q16_16(-1) < Q16_16(0));
  // 0.1 is not representable: exact comparison says so, Fixed comparison
  // compares the rounded constant.
  EXPECT_NE(Q16_16(0.1), 0.1);
  EXPECT_EQ(Q16_16(0.1), Q16_16(0.1));
  EXPECT_FALSE(Q16_16(0) < std::numeric_limits<double>::quiet_NaN());
}

// ---- limits and traits -----------------------------------------------------

TEST_F(FixedPointTest, NumericLimitsAndNumTraits) {
  using L = std::numeric_limits<Q16_16>;
  static_assert(L::is_specialized && L::is_signed && !L::is_integer && !L::is_modulo);
  EXPECT_EQ(L::digits, 31);
  EXPECT_EQ(L::digits10, 9);
  EXPECT_EQ(L::epsilon().raw(), 1);
  EXPECT_EQ(L::min().raw(), 1);
  EXPECT_EQ(L::max().raw(), INT32_MAX);
  EXPECT_EQ(L::lowest().raw(), INT32_MIN);

  using NT = Eigen::NumTraits<Q16_16>;
  static_assert(NT::IsComplex == 0 && NT::IsInteger == 0 && NT::IsSigned == 1);
  static_assert(NT::RequireInitialization == 0);
  EXPECT_EQ(NT::epsilon().raw(), 1);
  EXPECT_GT(NT::dummy_precision().raw(), 1);
  EXPECT_LT(NT::dummy_precision().raw(), 16);
  EXPECT_EQ(NT::highest(), L::max());
  EXPECT_EQ(NT::lowest(), L::lowest());
  EXPECT_EQ(NT::digits10(), 9);

  using L2 = std::numeric_limits<Fixed<24, 12>>;
  EXPECT_EQ(L2::max().raw(), (1 << 23) - 1);
  EXPECT_EQ(L2::lowest().raw(), -(1 << 23));
  EXPECT_DOUBLE_EQ(L2::epsilon().to_double(), 1.0 / 4096.0);
}

TEST_F(FixedPointTest, ScalarName) {
  EXPECT_STREQ(rbdgrad::scalar_name<double>(), "f64");
  EXPECT_STREQ(rbdgrad::scalar_name<float>(), "f32");
  EXPECT_STREQ(rbdgrad::scalar_name<Q16_16>(), "fixed");
  EXPECT_STREQ((rbdgrad::scalar_name<Fixed<32, 20>>()), "fixed<32,20>");
  EXPECT_STREQ((rbdgrad::scalar_name<Fixed<8, 4>>()), "fixed<8,4>");
  EXPECT_STREQ(rbdgrad::scalar_name<int>(), "unknown");
}

TEST_F(FixedPointTest, StreamsAsDecimal) {
  std::ostringstream os;
  os << Q16_16(-2.75);
  EXPECT_EQ(os.str(), "-2.75");
}

// ---- other formats ----------------------------------------------------------

TEST_F(FixedPointTest, OtherFormats) {
  using Q12_20 = Fixed<32, 20>;
  const double lsb20 = 1.0 / 1048576.0;
  EXPECT_EQ(Q12_20(1.0).raw(), 1 << 20);
  EXPECT_EQ(Q12_20(1.4 * lsb20).raw(), 1);
  EXPECT_EQ((Q12_20(1.5) * Q12_20(-1.25)), -1.875);
  EXPECT_EQ((Q12_20(1) / Q12_20(3)).raw(), 349525);  // 349525.33
  EXPECT_LE(std::abs(sqrt(Q12_20(2)).to_double() - std::sqrt(2.0)), 0.5 * lsb20);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(Q12_20(2048.0).raw(), INT32_MAX);  // range is [-2048, 2048)
  EXPECT_EQ(FixedPointStatus::count(), 1u);

  // 24-bit format in 32-bit storage must saturate at 24 bits, not 32.
  FixedPointStatus::clear();
  using Q12_12 = Fixed<24, 12>;
  EXPECT_EQ(Q12_12(2047.0).raw(), 2047 * 4096);
  EXPECT_EQ((Q12_12(1000) + Q12_12(1000)).raw(), 2000 * 4096);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ((Q12_12(2000) + Q12_12(100)).raw(), (1 << 23) - 1);
  EXPECT_EQ((Q12_12(-2000) * Q12_12(2)).raw(), -(1 << 23));
  EXPECT_EQ(FixedPointStatus::count(), 2u);

  // 8-bit storage: int8 arithmetic still goes through 64 bits.
  FixedPointStatus::clear();
  using Q4_4 = Fixed<8, 4>;
  EXPECT_EQ((Q4_4(3.5) * Q4_4(2)).raw(), 112);
  EXPECT_EQ((Q4_4(7) * Q4_4(2)).raw(), 127);
  EXPECT_EQ(FixedPointStatus::count(), 1u);
}

// Formats wider than 32 bits (the FPGA kernel's wider datapaths): int64 storage, exact 128-bit
// intermediates, the same rounding and saturation rules.
TEST_F(FixedPointTest, WideFormats) {
  using Q24_24 = Fixed<48, 24>;
  static_assert(sizeof(Q24_24) == 8);
  static_assert(Q24_24::raw_max == (std::int64_t{1} << 47) - 1);
  const double lsb = 1.0 / 16777216.0;
  EXPECT_EQ(Q24_24(1.0).raw(), 1 << 24);
  EXPECT_EQ(Q24_24(1.4 * lsb).raw(), 1);
  EXPECT_EQ(Q24_24(-1.5 * lsb).raw(), -2);  // ties away from zero
  EXPECT_EQ((Q24_24(1.5) * Q24_24(-1.25)), -1.875);
  EXPECT_EQ((Q24_24(1) / Q24_24(3)).raw(), 5592405);  // 5592405.33
  EXPECT_EQ((Q24_24(-2) / Q24_24(3)).raw(), -11184811);  // -11184810.67
  EXPECT_LE(std::abs(sqrt(Q24_24(2)).to_double() - std::sqrt(2.0)), 0.5 * lsb);
  // products of large values need more than 64 bits before rounding
  EXPECT_EQ((Q24_24(4000000.0) * Q24_24(2.0)).to_double(), 8000000.0);
  EXPECT_EQ((Q24_24(-8388607.5) / Q24_24(-1.0)).to_double(), 8388607.5);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  // range [-2^23, 2^23): saturation with the flag on every operation
  EXPECT_EQ(Q24_24(8388608.0).raw(), Q24_24::raw_max);
  EXPECT_EQ((Q24_24(8000000) + Q24_24(800000)).raw(), Q24_24::raw_max);
  EXPECT_EQ((Q24_24(-4000000) * Q24_24(4)).raw(), Q24_24::raw_min);
  EXPECT_EQ((Q24_24(1) / Q24_24(0)).raw(), Q24_24::raw_max);
  EXPECT_EQ(FixedPointStatus::count(), 4u);

  FixedPointStatus::clear();
  using Q32_32 = Fixed<64, 32>;
  static_assert(sizeof(Q32_32) == 8);
  static_assert(Q32_32::raw_max == std::numeric_limits<std::int64_t>::max());
  static_assert(Q32_32::raw_min == std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(Q32_32(-2147483648.0).raw(), Q32_32::raw_min);  // the lowest value fits exactly
  EXPECT_EQ((Q32_32(3.0) * Q32_32(-0.5)), -1.5);
  EXPECT_EQ((Q32_32(1) / Q32_32(3)).raw(), 1431655765);  // 2^32 / 3 = 1431655765.33
  EXPECT_LE(std::abs(sqrt(Q32_32(2)).to_double() - std::sqrt(2.0)), 1e-9);
  // the widest intermediate: raw_max << 32 needs 95 bits
  EXPECT_NEAR(sqrt(std::numeric_limits<Q32_32>::max()).to_double(), std::sqrt(2147483648.0), 1e-9);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(Q32_32(2147483648.0).raw(), Q32_32::raw_max);
  EXPECT_EQ((-std::numeric_limits<Q32_32>::lowest()).raw(), Q32_32::raw_max);
  EXPECT_EQ((Q32_32(2147483647.0) + Q32_32(1.0)).raw(), Q32_32::raw_max);
  EXPECT_EQ((Q32_32(-100000.0) * Q32_32(100000.0)).raw(), Q32_32::raw_min);
  EXPECT_EQ(Q32_32(std::int64_t{1} << 40).raw(), Q32_32::raw_max);
  EXPECT_EQ(FixedPointStatus::count(), 5u);

  // random operands: within half an LSB of the exact result (plus double's own rounding)
  FixedPointStatus::clear();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-2000.0, 2000.0);
  for (int k = 0; k < 2000; ++k) {
    const Q24_24 a = u(rng), b = u(rng);
    const double x = a.to_double(), y = b.to_double();
    ASSERT_LE(std::abs((a * b).to_double() - x * y), 0.5 * lsb + std::abs(x * y) * 0x1p-52) << x << " * " << y;
    ASSERT_LE(std::abs((a / b).to_double() - x / y), 0.5 * lsb + std::abs(x / y) * 0x1p-52) << x << " / " << y;
    ASSERT_EQ((a + b).to_double(), x + y);
  }
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_STREQ((rbdgrad::scalar_name<Q24_24>()), "fixed<48,24>");
}

TEST_F(FixedPointTest, ConversionBetweenFormats) {
  // into and out of a wide format
  using Q24_24 = Fixed<48, 24>;
  EXPECT_EQ(Q24_24(Q16_16(-3.25)), -3.25);
  EXPECT_EQ(Q16_16(Q24_24::from_raw(384)).raw(), 2);  // 1.5 LSB of Q16.16 rounds away from zero
  EXPECT_EQ(Q24_24(Fixed<64, 32>(1000000.5)), 1000000.5);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(Q16_16(Q24_24(40000)).raw(), INT32_MAX);
  EXPECT_EQ(Q24_24(Fixed<64, 32>(1e9)).raw(), Q24_24::raw_max);
  EXPECT_EQ(FixedPointStatus::count(), 2u);
  FixedPointStatus::clear();

  using Q12_20 = Fixed<32, 20>;
  const Q16_16 a = Q16_16(Q12_20::from_raw(24));  // 1.5 LSB of Q16.16
  EXPECT_EQ(a.raw(), 2);
  EXPECT_EQ(Q16_16(Q12_20::from_raw(-24)).raw(), -2);
  EXPECT_EQ(Q12_20(Q16_16(-3.25)), -3.25);
  EXPECT_FALSE(FixedPointStatus::overflowed());
  EXPECT_EQ(Q12_20(Q16_16(5000)).raw(), INT32_MAX);
  EXPECT_TRUE(FixedPointStatus::overflowed());
}

// ---- Eigen -----------------------------------------------------------------

TEST_F(FixedPointTest, EigenMatrixVectorMatchesDouble) {
  using M6 = Eigen::Matrix<Q16_16, 6, 6>;
  using V6 = Eigen::Matrix<Q16_16, 6, 1>;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> dist(-10.0, 10.0);
  for (int trial = 0; trial < 100; ++trial) {
    Eigen::Matrix<double, 6, 6> Ad;
    Eigen::Matrix<double, 6, 1> vd;
    for (int i = 0; i < 36; ++i) Ad(i) = dist(rng);
    for (int i = 0; i < 6; ++i) vd(i) = dist(rng);
    const M6 A = Ad.cast<Q16_16>();
    const V6 v = vd.cast<Q16_16>();
    const V6 y = A * v;
    // Reference on the already-quantised inputs: only the 6 product roundings
    // (<= 0.5 LSB each) separate the results.
    const Eigen::Matrix<double, 6, 1> ref = A.cast<double>() * v.cast<double>();
    for (int i = 0; i < 6; ++i) {
      ASSERT_LE(std::abs(y(i).to_double() - ref(i)), 3.0 * kLsb) << "row " << i;
    }
    // And against the unquantised inputs, within input quantisation error.
    const Eigen::Matrix<double, 6, 1> ref_exact = Ad * vd;
    for (int i = 0; i < 6; ++i) {
      ASSERT_LE(std::abs(y(i).to_double() - ref_exact(i)), 6 * 21 * kLsb);
    }
  }
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, EigenOperationsCompileAndWork) {
  using M6 = Eigen::Matrix<Q16_16, 6, 6>;
  M6 A;
  A.setIdentity();
  EXPECT_EQ(A(0, 0), 1.0);
  EXPECT_EQ(A(0, 1), 0.0);
  M6 B;
  B.setZero();
  EXPECT_EQ(B(3, 2), 0.0);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) B(i, j) = Q16_16(0.25 * (i - j));
  }
  const M6 C = (A * B).eval();
  EXPECT_EQ(C, B);
  EXPECT_EQ(B.transpose()(1, 4), B(4, 1));
  EXPECT_EQ((B + B.transpose()).norm(), 0.0);  // B is antisymmetric
  EXPECT_EQ((2.0 * B)(5, 0), 2.5);             // scalar promoted to Fixed
  EXPECT_EQ((B * 2)(5, 0), 2.5);

  Eigen::Matrix<Q16_16, 3, 1> v(Q16_16(1), Q16_16(2), Q16_16(2));
  EXPECT_EQ(v.norm(), 3.0);
  EXPECT_EQ(v.squaredNorm(), 9.0);
  EXPECT_EQ(v.dot(v), 9.0);
  EXPECT_EQ(v.cross(Eigen::Matrix<Q16_16, 3, 1>::UnitX())(2), -2.0);
  EXPECT_EQ(v.maxCoeff(), 2.0);
  EXPECT_EQ(v.cwiseAbs().sum(), 5.0);

  Eigen::Matrix<Q16_16, 3, 3> R = Eigen::Matrix<Q16_16, 3, 3>::Identity();
  EXPECT_TRUE((R * R.transpose()).isApprox(R));
  EXPECT_TRUE(R.allFinite());

  // Dynamic sizes go through Eigen's blocked GEMM path.
  Eigen::Matrix<Q16_16, Eigen::Dynamic, Eigen::Dynamic> D(20, 20);
  Eigen::MatrixXd Dd(20, 20);
  for (Eigen::Index i = 0; i < 20; ++i) {
    for (Eigen::Index j = 0; j < 20; ++j) {
      Dd(i, j) = 0.01 * static_cast<double>(i * 20 + j) - 2.0;
      D(i, j) = Q16_16(Dd(i, j));
    }
  }
  const Eigen::Matrix<Q16_16, Eigen::Dynamic, Eigen::Dynamic> DD = D * D;
  const Eigen::MatrixXd ref = D.cast<double>() * D.cast<double>();
  EXPECT_LE((DD.cast<double>() - ref).cwiseAbs().maxCoeff(), 10.0 * kLsb);
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, EigenCastRoundTrip) {
  Eigen::Matrix<double, 6, 6> Ad;
  for (int i = 0; i < 36; ++i) Ad(i) = 0.37 * i - 5.0;
  const Eigen::Matrix<Q16_16, 6, 6> Af = Ad.cast<Q16_16>();
  const Eigen::Matrix<double, 6, 6> back = Af.cast<double>();
  EXPECT_LE((back - Ad).cwiseAbs().maxCoeff(), 0.5 * kLsb);
  EXPECT_GT((back - Ad).cwiseAbs().maxCoeff(), 0.0);  // 0.37 is not representable

  // Representable values survive exactly, also through float.
  Eigen::Matrix3d Rd;
  Rd << 1.0, -0.5, 0.25, 2.0, -3.0, 0.125, 100.0, -100.0, 0.0;
  EXPECT_EQ(Rd.cast<Q16_16>().cast<double>(), Rd);
  EXPECT_EQ(Rd.cast<float>().cast<Q16_16>().cast<float>(), Rd.cast<float>());
  EXPECT_EQ((Rd.cast<Q16_16>().cast<Fixed<32, 20>>().cast<double>()), Rd);
  EXPECT_FALSE(FixedPointStatus::overflowed());

  // Out-of-range entries saturate and flag during the cast.
  Rd(0, 0) = 1e6;
  EXPECT_EQ(Rd.cast<Q16_16>()(0, 0), std::numeric_limits<Q16_16>::max());
  EXPECT_TRUE(FixedPointStatus::overflowed());
}

TEST_F(FixedPointTest, EigenProductInOtherFormat) {
  using Q = Fixed<32, 20>;
  const double lsb = 1.0 / 1048576.0;
  Eigen::Matrix<double, 6, 6> Ad;
  Eigen::Matrix<double, 6, 1> vd;
  for (int i = 0; i < 36; ++i) Ad(i) = std::sin(0.3 * i);
  for (int i = 0; i < 6; ++i) vd(i) = std::cos(0.7 * i);
  const Eigen::Matrix<Q, 6, 6> A = Ad.cast<Q>();
  const Eigen::Matrix<Q, 6, 1> v = vd.cast<Q>();
  const Eigen::Matrix<double, 6, 1> diff =
      (A * v).cast<double>() - A.cast<double>() * v.cast<double>();
  EXPECT_LE(diff.cwiseAbs().maxCoeff(), 3.0 * lsb);
  EXPECT_FALSE(FixedPointStatus::overflowed());
}

}  // namespace
