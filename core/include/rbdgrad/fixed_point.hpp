// Saturating fixed-point scalar that models what an FPGA HLS kernel computes.
//
// Overview
//   template <int TotalBits = 32, int FracBits = 16> class rbdgrad::Fixed;
//   using rbdgrad::Q16_16 = Fixed<32, 16>;
//
//   A Fixed stores round(x * 2^FracBits) in the smallest signed integer that
//   holds TotalBits (int8_t / int16_t / int32_t / int64_t; TotalBits <= 64).
//   It is a drop-in Scalar for Eigen matrices and for the templated dynamics
//   algorithms.  Intermediate results (sums, full products) are exact in a
//   wider integer: int64_t up to 32 bits, the compiler's 128-bit integer above.
//
// Arithmetic semantics (equivalent to HLS ap_fixed<T, T-F, AP_RND_INF, AP_SAT>)
//   * Rounding: to nearest, ties away from zero, on every conversion,
//     multiplication and division.  Addition/subtraction are exact.
//   * Saturation: any result outside [lowest(), max()] is clamped to the
//     nearest bound AND recorded in the overflow status below.  There is never
//     a silent wrap-around (this includes -lowest() and abs(lowest())).
//   * Division by zero: x/0 gives max() for x > 0, lowest() for x < 0 and 0 for
//     0/0; all three record an overflow.  NaN converts to 0 and records one.
//   * Mixed arithmetic (Fixed op double/int) first converts the other operand
//     to Fixed, exactly like a constant baked into an FPGA kernel.  Mixed
//     comparisons (Fixed vs double/int) compare exact values and never flag.
//   * An overflow inside constant evaluation is a compile error (the status
//     cannot be recorded at compile time, and silent saturation is banned).
//
// Overflow status API (thread_local, so parallel workers never interfere):
//   rbdgrad::FixedPointStatus::overflowed()  -> bool      any overflow since clear()
//   rbdgrad::FixedPointStatus::count()       -> uint64_t  number of overflows since clear()
//   rbdgrad::FixedPointStatus::clear()                    reset this thread's status
//   rbdgrad::FixedOverflowScope s; ... s.overflowed()/s.count()
//                                  overflows in this thread since `s` was built
//                                  (does not clear, so it nests safely).
//   The status is sticky: it stays set until clear() is called on that thread.
//
// Math functions (hidden friends, found by ADL, e.g. `using std::sqrt; sqrt(x)`
// as Eigen does): abs, fabs, sqrt, sin, cos, isfinite, isnan, isinf, min, max.
// sqrt is an exact integer square root (correctly rounded).  sin/cos are
// computed through double and rounded: on the FPGA target the host precomputes
// sin/cos of joint angles, so the kernel never evaluates them in fixed point.
//
// Traits: rbdgrad::is_fixed_point_v<S>, rbdgrad::scalar_name<S>() ("f64",
// "f32", "fixed" for Q16.16, "fixed<T,F>" otherwise, "unknown" for others),
// std::numeric_limits<Fixed<T,F>> and Eigen::NumTraits<Fixed<T,F>>.
#pragma once

#include <array>
#include <cmath>
#include <compare>
#include <concepts>
#include <cstdint>
#include <iosfwd>
#include <limits>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

namespace rbdgrad {

namespace detail {

// One counter per thread: workers evaluating kernels in parallel each see
// only their own overflows.
inline thread_local std::uint64_t fixed_overflow_count = 0;

// Deliberately not constexpr: reaching it during constant evaluation makes the
// expression non-constant, turning a compile-time overflow into an error.
inline void record_fixed_overflow() noexcept { ++fixed_overflow_count; }

// 128-bit integers (a GCC and Clang extension; __extension__ keeps -Wpedantic quiet): the exact
// intermediates of formats wider than 32 bits.
__extension__ typedef __int128 int128;
__extension__ typedef unsigned __int128 uint128;

// Smallest standard signed integer with at least `Bits` bits.
template <int Bits>
using fixed_storage_t = std::conditional_t<
    (Bits <= 8), std::int8_t,
    std::conditional_t<(Bits <= 16), std::int16_t, std::conditional_t<(Bits <= 32), std::int32_t, std::int64_t>>>;

// Signed integer that holds the sum and the full product of two `Bits`-bit values exactly.
template <int Bits>
using fixed_wide_t = std::conditional_t<(Bits <= 32), std::int64_t, int128>;

// Divide by 2^shift, rounding to nearest with ties away from zero.  Works on
// the magnitude so negative values round symmetrically (a plain arithmetic
// shift would round -0.5 towards +inf).
template <class W>
constexpr W round_shift_right(W v, int shift) noexcept {
  if (shift <= 0) return v;
  const W half = W{1} << (shift - 1);
  return v >= 0 ? (v + half) >> shift : -((-v + half) >> shift);
}

// floor(sqrt(n)), bit by bit: exact and constexpr, as an FPGA core would do.
// U is std::uint64_t or uint128.
template <class U>
constexpr U isqrt(U n) noexcept {
  U res = 0;
  U bit = U{1} << (8 * sizeof(U) - 2);
  while (bit > n) bit >>= 2;
  while (bit != 0) {
    if (n >= res + bit) {
      n -= res + bit;
      res = (res >> 1) + bit;
    } else {
      res >>= 1;
    }
    bit >>= 2;
  }
  return res;
}

}  // namespace detail

// Per-thread overflow status shared by every Fixed<T,F> format.
struct FixedPointStatus {
  static bool overflowed() noexcept { return detail::fixed_overflow_count != 0; }
  static std::uint64_t count() noexcept { return detail::fixed_overflow_count; }
  static void clear() noexcept { detail::fixed_overflow_count = 0; }
};

// Counts overflows of the current thread from construction on, without
// clearing the sticky status (so an outer caller's status is preserved).
class FixedOverflowScope {
 public:
  FixedOverflowScope() noexcept : start_(FixedPointStatus::count()) {}
  std::uint64_t count() const noexcept { return FixedPointStatus::count() - start_; }
  bool overflowed() const noexcept { return count() != 0; }

 private:
  std::uint64_t start_;
};

template <int TotalBits = 32, int FracBits = 16>
class Fixed {
  // FracBits <= 62: 2^FracBits stays a positive int64
  static_assert(1 <= FracBits && FracBits < TotalBits && TotalBits <= 64 && FracBits <= 62,
                "Fixed<TotalBits, FracBits> requires 1 <= FracBits < TotalBits <= 64 and FracBits <= 62");

 public:
  using storage_type = detail::fixed_storage_t<TotalBits>;
  // exact sums and products before rounding and saturation
  using wide_type = detail::fixed_wide_t<TotalBits>;

  static constexpr int total_bits = TotalBits;
  static constexpr int frac_bits = FracBits;
  static constexpr int int_bits = TotalBits - FracBits;  // including the sign bit
  // Bounds of the TotalBits-wide two's-complement range (may be narrower than
  // storage_type, e.g. Fixed<24,12> stored in int32_t).
  static constexpr std::int64_t raw_max =
      TotalBits == 64 ? std::numeric_limits<std::int64_t>::max() : (std::int64_t{1} << (TotalBits - 1)) - 1;
  static constexpr std::int64_t raw_min = -raw_max - 1;

  constexpr Fixed() noexcept = default;

  // Implicit on purpose: lets Eigen and templated code write Scalar(0),
  // Scalar(0.5), `x * 2.0`, and makes double -> Fixed casts work.
  template <std::floating_point D>
  constexpr Fixed(D value) noexcept : v_(from_double(static_cast<double>(value))) {}

  template <std::integral I>
    requires(!std::same_as<I, bool>)
  constexpr Fixed(I value) noexcept : v_(from_integer(value)) {}

  // Change of format: rescale with rounding to nearest, then saturate.
  template <int T2, int F2>
    requires(T2 != TotalBits || F2 != FracBits)
  explicit constexpr Fixed(Fixed<T2, F2> other) noexcept {
    using W = detail::fixed_wide_t<(TotalBits > T2 ? TotalBits : T2)>;
    W r = other.raw();
    if constexpr (F2 > FracBits) {
      r = detail::round_shift_right(r, F2 - FracBits);
    } else {
      r *= W{1} << (FracBits - F2);  // |r| < 2^(T2 - 1 + FracBits - F2): fits W
    }
    v_ = saturate_wide(r);
  }

  // Bit-exact construction from the integer representation (saturating).
  static constexpr Fixed from_raw(std::int64_t raw) noexcept { return from_wide(raw); }

  constexpr storage_type raw() const noexcept { return v_; }

  // Exact up to 53 significant bits (every format of up to 53 bits); wider values round to
  // the nearest double.
  constexpr double to_double() const noexcept { return static_cast<double>(v_) * kInvScale; }

  template <std::floating_point D>
  explicit constexpr operator D() const noexcept {
    return static_cast<D>(to_double());
  }

  // ---- arithmetic ---------------------------------------------------------
  constexpr Fixed operator+() const noexcept { return *this; }
  constexpr Fixed operator-() const noexcept { return from_wide(-wide_type{v_}); }

  friend constexpr Fixed operator+(Fixed a, Fixed b) noexcept { return from_wide(wide_type{a.v_} + wide_type{b.v_}); }
  friend constexpr Fixed operator-(Fixed a, Fixed b) noexcept { return from_wide(wide_type{a.v_} - wide_type{b.v_}); }
  // Full product (|p| <= 2^(2 TotalBits - 2): fits wide_type), rounded back to FracBits.
  friend constexpr Fixed operator*(Fixed a, Fixed b) noexcept {
    const wide_type p = wide_type{a.v_} * wide_type{b.v_};
    return from_wide(detail::round_shift_right(p, FracBits));
  }
  // (a << FracBits) / b in wide_type, rounded to nearest (ties away from zero).
  friend constexpr Fixed operator/(Fixed a, Fixed b) noexcept {
    if (b.v_ == 0) {
      detail::record_fixed_overflow();
      if (a.v_ > 0) return from_raw(raw_max);
      if (a.v_ < 0) return from_raw(raw_min);
      return Fixed{};
    }
    const wide_type num = wide_type{a.v_} * (wide_type{1} << FracBits);
    const wide_type den = b.v_;
    wide_type q = num / den;
    const wide_type r = num % den;
    const wide_type abs_r = r < 0 ? -r : r;
    const wide_type abs_d = den < 0 ? -den : den;
    if (2 * abs_r >= abs_d) q += ((num < 0) != (den < 0)) ? -1 : 1;
    return from_wide(q);
  }

  constexpr Fixed& operator+=(Fixed o) noexcept { return *this = *this + o; }
  constexpr Fixed& operator-=(Fixed o) noexcept { return *this = *this - o; }
  constexpr Fixed& operator*=(Fixed o) noexcept { return *this = *this * o; }
  constexpr Fixed& operator/=(Fixed o) noexcept { return *this = *this / o; }

  // ---- comparisons --------------------------------------------------------
  friend constexpr bool operator==(Fixed a, Fixed b) noexcept { return a.v_ == b.v_; }
  friend constexpr std::strong_ordering operator<=>(Fixed a, Fixed b) noexcept {
    return a.v_ <=> b.v_;
  }
  // Exact comparison against double/float/int (no rounding of the other side,
  // and no overflow flag for e.g. `x < 1e10`).  Ints reach these through the
  // standard int -> double conversion, which beats the user-defined one.
  friend constexpr bool operator==(Fixed a, double b) noexcept { return a.to_double() == b; }
  friend constexpr std::partial_ordering operator<=>(Fixed a, double b) noexcept {
    return a.to_double() <=> b;
  }

  // ---- math (hidden friends: found by ADL only, so they never hide
  // std::sqrt(double) etc. for unqualified calls elsewhere in rbdgrad) -----
  friend constexpr Fixed abs(Fixed x) noexcept { return x.v_ < 0 ? -x : x; }
  friend constexpr Fixed fabs(Fixed x) noexcept { return abs(x); }
  friend constexpr Fixed min(Fixed a, Fixed b) noexcept { return b < a ? b : a; }
  friend constexpr Fixed max(Fixed a, Fixed b) noexcept { return a < b ? b : a; }

  // Correctly rounded: raw = round(sqrt(raw_x * 2^FracBits)).  Negative input
  // gives 0 and records an overflow (there is no NaN to return).
  friend constexpr Fixed sqrt(Fixed x) noexcept {
    if (x.v_ < 0) {
      detail::record_fixed_overflow();
      return Fixed{};
    }
    using U = std::conditional_t<(TotalBits <= 32), std::uint64_t, detail::uint128>;
    const U n = static_cast<U>(x.v_) << FracBits;  // < 2^(TotalBits - 1 + FracBits)
    U r = detail::isqrt(n);
    if (n - r * r > r) ++r;  // n > (r + 1/2)^2  <=>  n - r^2 > r for integers
    return from_wide(static_cast<wide_type>(r));
  }
  // Through double: the FPGA host precomputes sin/cos, the kernel consumes them.
  friend Fixed sin(Fixed x) noexcept { return Fixed(std::sin(x.to_double())); }
  friend Fixed cos(Fixed x) noexcept { return Fixed(std::cos(x.to_double())); }

  friend constexpr bool isfinite(Fixed) noexcept { return true; }
  friend constexpr bool isnan(Fixed) noexcept { return false; }
  friend constexpr bool isinf(Fixed) noexcept { return false; }

  // Template so that only <iosfwd> is needed here; used by Eigen printing and
  // by GoogleTest failure messages.
  template <class CharT, class Traits>
  friend std::basic_ostream<CharT, Traits>& operator<<(std::basic_ostream<CharT, Traits>& os,
                                                       Fixed x) {
    return os << x.to_double();
  }

 private:
  static constexpr double kScale = static_cast<double>(std::int64_t{1} << FracBits);
  static constexpr double kInvScale = 1.0 / kScale;  // exact: power of two

  // Clamps an exact intermediate to the format's range, recording an overflow when it must.
  template <class W>
  static constexpr storage_type saturate_wide(W r) noexcept {
    if (r > W{raw_max}) return saturated_high();
    if (r < W{raw_min}) return saturated_low();
    return static_cast<storage_type>(r);
  }
  template <class W>
  static constexpr Fixed from_wide(W r) noexcept {
    Fixed f;
    f.v_ = saturate_wide(r);
    return f;
  }
  static constexpr storage_type saturated_high() noexcept {
    detail::record_fixed_overflow();
    return static_cast<storage_type>(raw_max);
  }
  static constexpr storage_type saturated_low() noexcept {
    detail::record_fixed_overflow();
    return static_cast<storage_type>(raw_min);
  }

  static constexpr storage_type from_double(double x) noexcept {
    if (x != x) {  // NaN: no representation, report it
      detail::record_fixed_overflow();
      return 0;
    }
    const double s = x * kScale;  // exact (power-of-two scaling)
    // Limits at +-half an LSB beyond the range: those round outside it.
    // Checked before the integer cast, which would be UB out of range.
    // Beyond 53 bits the bounds round to +-2^(TotalBits - 1) (powers of two, exact), and the
    // comparisons below still let through exactly the values that fit.
    constexpr bool kExactBounds = TotalBits <= 53;
    constexpr double kHigh = static_cast<double>(raw_max) + 0.5;
    constexpr double kLow = static_cast<double>(raw_min) - 0.5;
    if (s >= kHigh) return saturated_high();
    if (kExactBounds ? s <= kLow : s < kLow) return saturated_low();
    // Round to nearest, ties away from zero (std::round is not constexpr).
    std::int64_t t = static_cast<std::int64_t>(s);  // truncates towards zero
    const double frac = s - static_cast<double>(t);  // exact, |frac| < 1
    if (frac >= 0.5) ++t;
    if (frac <= -0.5) --t;
    return static_cast<storage_type>(t);
  }

  template <class I>
  static constexpr storage_type from_integer(I x) noexcept {
    // Compare before shifting so large 64-bit / unsigned inputs cannot overflow.
    constexpr std::int64_t int_max = raw_max >> FracBits;
    constexpr std::int64_t int_min = raw_min >> FracBits;  // exact: low bits are 0
    if (std::cmp_greater(x, int_max)) return saturated_high();
    if (std::cmp_less(x, int_min)) return saturated_low();
    return static_cast<storage_type>(static_cast<std::int64_t>(x) * (std::int64_t{1} << FracBits));
  }

  storage_type v_ = 0;
};

using Q16_16 = Fixed<32, 16>;

// ---- traits ---------------------------------------------------------------

template <class S>
struct is_fixed_point : std::false_type {};
template <int T, int F>
struct is_fixed_point<Fixed<T, F>> : std::true_type {};

template <class S>
inline constexpr bool is_fixed_point_v = is_fixed_point<std::remove_cv_t<S>>::value;

namespace detail {

// "fixed<T,F>" built at compile time so scalar_name can return a const char*.
template <int T, int F>
struct FixedFormatName {
  static constexpr std::array<char, 16> make() noexcept {
    std::array<char, 16> out{};
    std::size_t n = 0;
    auto put_int = [&](int v) {
      if (v >= 10) out[n++] = static_cast<char>('0' + v / 10);
      out[n++] = static_cast<char>('0' + v % 10);
    };
    for (char c : {'f', 'i', 'x', 'e', 'd', '<'}) out[n++] = c;
    put_int(T);
    out[n++] = ',';
    put_int(F);
    out[n++] = '>';
    return out;  // remaining chars are '\0'
  }
  static constexpr std::array<char, 16> value = make();
};

template <class S>
struct fixed_name;
template <int T, int F>
struct fixed_name<Fixed<T, F>> {
  static constexpr const char* get() noexcept {
    if constexpr (T == 32 && F == 16) {
      return "fixed";
    } else {
      return FixedFormatName<T, F>::value.data();
    }
  }
};

}  // namespace detail

// Short label for logs/benchmarks: "f64", "f32", "fixed" (Q16.16),
// "fixed<T,F>" (other formats), "unknown" otherwise.
template <class S>
constexpr const char* scalar_name() noexcept {
  using U = std::remove_cv_t<S>;
  if constexpr (std::is_same_v<U, double>) {
    return "f64";
  } else if constexpr (std::is_same_v<U, float>) {
    return "f32";
  } else if constexpr (is_fixed_point_v<U>) {
    return detail::fixed_name<U>::get();
  } else {
    return "unknown";
  }
}

}  // namespace rbdgrad

// ---- std::numeric_limits ----------------------------------------------------
// Follows the floating-point conventions since is_integer is false:
// min() is the smallest positive value (one LSB), lowest() the most negative.
namespace std {
template <int T, int F>
class numeric_limits<rbdgrad::Fixed<T, F>> {
  using X = rbdgrad::Fixed<T, F>;

 public:
  static constexpr bool is_specialized = true;
  static constexpr bool is_signed = true;
  static constexpr bool is_integer = false;
  static constexpr bool is_exact = true;
  static constexpr bool has_infinity = false;
  static constexpr bool has_quiet_NaN = false;
  static constexpr bool has_signaling_NaN = false;
  static constexpr std::float_denorm_style has_denorm = std::denorm_absent;
  static constexpr bool has_denorm_loss = false;
  static constexpr std::float_round_style round_style = std::round_to_nearest;
  static constexpr bool is_iec559 = false;
  static constexpr bool is_bounded = true;
  static constexpr bool is_modulo = false;  // saturates, never wraps
  static constexpr int digits = T - 1;      // value bits, sign excluded
  static constexpr int digits10 = (T - 1) * 30103 / 100000;
  static constexpr int max_digits10 = (T - 1) * 30103 / 100000 + 2;
  static constexpr int radix = 2;
  static constexpr int min_exponent = 0;
  static constexpr int min_exponent10 = 0;
  static constexpr int max_exponent = 0;
  static constexpr int max_exponent10 = 0;
  static constexpr bool traps = false;
  static constexpr bool tinyness_before = false;

  static constexpr X min() noexcept { return X::from_raw(1); }
  static constexpr X max() noexcept { return X::from_raw(X::raw_max); }
  static constexpr X lowest() noexcept { return X::from_raw(X::raw_min); }
  static constexpr X epsilon() noexcept { return X::from_raw(1); }
  // The true bound (half an LSB) is not representable; one LSB bounds it.
  static constexpr X round_error() noexcept { return X::from_raw(1); }
  // No inf/NaN: infinity() gives the saturation value, NaNs give 0 (what a
  // NaN converts to).
  static constexpr X infinity() noexcept { return max(); }
  static constexpr X quiet_NaN() noexcept { return X(); }
  static constexpr X signaling_NaN() noexcept { return X(); }
  static constexpr X denorm_min() noexcept { return X::from_raw(1); }
};
}  // namespace std

// ---- Eigen integration ------------------------------------------------------
namespace Eigen {

template <int T, int F>
struct NumTraits<rbdgrad::Fixed<T, F>> : GenericNumTraits<rbdgrad::Fixed<T, F>> {
  using Self = rbdgrad::Fixed<T, F>;
  using Real = Self;
  using NonInteger = Self;
  using Literal = Self;
  using Nested = Self;

  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 0,
    ReadCost = 1,
    AddCost = 1,  // one saturating adder
    MulCost = 3   // DSP multiply + round + saturate
  };

  static constexpr Self epsilon() noexcept { return Self::from_raw(1); }
  // A few LSB: the accumulated rounding of short dot products.
  static constexpr Self dummy_precision() noexcept { return Self::from_raw(4); }
  static constexpr Self highest() noexcept { return Self::from_raw(Self::raw_max); }
  static constexpr Self lowest() noexcept { return Self::from_raw(Self::raw_min); }
  static constexpr Self infinity() noexcept { return highest(); }
  static constexpr Self quiet_NaN() noexcept { return Self(); }
  static constexpr int digits10() noexcept { return std::numeric_limits<Self>::digits10; }
  static constexpr int digits() noexcept { return std::numeric_limits<Self>::digits; }
};

}  // namespace Eigen
