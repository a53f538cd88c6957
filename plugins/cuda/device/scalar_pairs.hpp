// Two scalars a shared-memory load. The block kernel's busiest unit is the shared-memory pipe
// (docs/benchmarks/cuda.md), and many of its reads are broadcasts: the lanes of a warp read the
// same 6-vector (a column's in d tau/d u's rows, a joint's in M^-1's passes) or the same row of
// M^-1, and a broadcast costs one wavefront a load whatever its width. Read as pairs (a 16-byte
// load in f64, 8 in f32), such a vector costs half the wavefronts and half the instructions (5.9%
// off the kernel at 65536 f64 talos_reduced states, 5.0% f32 batches: run 136, H100). The
// pair must start at an even index of an array aligned to two scalars: the lean working set
// (block_workspace.hpp) places its 6-vector arrays and M^-1 so. On the host (the tests) the pair
// is two plain reads, and a misaligned pair aborts, so that a layout that breaks the rule fails
// there too.
#pragma once

#include "spatial.hpp"

#if !defined(__CUDA_ARCH__)
#include <cstdint>
#include <cstdlib>
#endif

namespace rbdgrad::cuda {

// (a host tool tracing the shared-memory accesses names each pair by the code that asks for it:
// these inlined there)
#if defined(RBDGRAD_SHARED_TRACE) && !defined(__CUDA_ARCH__)
#define RBDGRAD_PAIR_HD [[gnu::always_inline]] inline
#else
#define RBDGRAD_PAIR_HD RBDGRAD_HD
#endif

#if !defined(__CUDA_ARCH__)
// A pair's access as one, for a host tool whose scalar type traces the kernel's shared-memory
// accesses (bench/plugins/shared_access_trace.hpp overloads it for its type); nothing otherwise.
template <class S>
void pair_access(const S*, bool /*store*/) {}
#endif

// p[0] and p[1] into a and b; p aligned to 2 sizeof(S)
template <class S>
RBDGRAD_PAIR_HD void load_pair(const S* p, S& a, S& b) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(S) == sizeof(double)) {
    const double2 v = *reinterpret_cast<const double2*>(p);
    a = v.x;
    b = v.y;
  } else {
    const float2 v = *reinterpret_cast<const float2*>(p);
    a = v.x;
    b = v.y;
  }
#else
  if (reinterpret_cast<std::uintptr_t>(p) % (2 * sizeof(S)) != 0) std::abort();
  pair_access(p, false);
  a = p[0];
  b = p[1];
#endif
}

// a and b into p[0] and p[1]; p aligned to 2 sizeof(S)
template <class S>
RBDGRAD_PAIR_HD void store_pair(S* p, S a, S b) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(S) == sizeof(double)) {
    *reinterpret_cast<double2*>(p) = double2{a, b};
  } else {
    *reinterpret_cast<float2*>(p) = float2{a, b};
  }
#else
  if (reinterpret_cast<std::uintptr_t>(p) % (2 * sizeof(S)) != 0) std::abort();
  pair_access(static_cast<const S*>(p), true);
  p[0] = a;
  p[1] = b;
#endif
}

// p[0] and p[1]: one load (kPairs, p aligned to 2 sizeof(S)), else two
template <bool kPairs, class S>
RBDGRAD_PAIR_HD void load_pair_or_two(const S* p, S& a, S& b) {
  if constexpr (kPairs) {
    load_pair(p, a, b);
  } else {
    a = p[0];
    b = p[1];
  }
}
// the same for a store
template <bool kPairs, class S>
RBDGRAD_PAIR_HD void store_pair_or_two(S* p, S a, S b) {
  if constexpr (kPairs) {
    store_pair(p, a, b);
  } else {
    p[0] = a;
    p[1] = b;
  }
}

// the 6-vector at p into x: as three pairs (kPairs, p aligned to 2 sizeof(S)), else a scalar a
// load (the layouts that do not align their vectors)
template <bool kPairs, class S>
RBDGRAD_PAIR_HD void load_six(const S* p, S (&x)[6]) {
  if constexpr (kPairs) {
    load_pair(p, x[0], x[1]);
    load_pair(p + 2, x[2], x[3]);
    load_pair(p + 4, x[4], x[5]);
  } else {
    for (int k = 0; k < 6; ++k) x[k] = p[k];
  }
}

// a, b or c as k is 0, 1 or 2: a component of a vector a thread holds, picked by selects (indexed
// at run time, ptxas would put the array in local memory)
template <class S>
RBDGRAD_HD S pick3(S a, S b, S c, int k) {
  return k == 0 ? a : k == 1 ? b : c;
}

}  // namespace rbdgrad::cuda
