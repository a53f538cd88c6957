// The few standard-library names the device code uses. nvcc and host compilers take them from the
// standard headers; NVRTC (the robot-specific kernel compiled at model load, kernel_source.cpp)
// has no standard library, so there they are declared here, as small as the device code needs.
#pragma once

#if defined(__CUDACC_RTC__)
namespace std {
using size_t = decltype(sizeof(0));
using uint32_t = unsigned int;
using uint64_t = unsigned long long;
static_assert(sizeof(uint32_t) == 4 && sizeof(uint64_t) == 8, "NVRTC's integer sizes");
template <class A, class B>
struct is_same {
  static constexpr bool value = false;
};
template <class A>
struct is_same<A, A> {
  static constexpr bool value = true;
};
template <class A, class B>
inline constexpr bool is_same_v = is_same<A, B>::value;
// NVRTC's built-in math functions (float and double overloads) are global
using ::cos;
using ::sin;
}  // namespace std
#else
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#endif
