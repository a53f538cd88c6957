// Spatial vector algebra for the fused kernel: small fixed-size types held in registers and the
// operations of core/include/rbdgrad/spatial.hpp, written without Eigen so that the same code
// compiles as CUDA device code and as plain C++ (the host tests run it on the CPU).
// Motion vectors are [angular; linear], force vectors [moment; force]; matrices are row-major.
#pragma once

#include "std_support.hpp"

#if defined(__CUDACC__)
#define RBDGRAD_HD __host__ __device__ __forceinline__
#else
#define RBDGRAD_HD inline
#endif

namespace rbdgrad::cuda {

template <class S> struct Vec3 { S v[3]; };
template <class S> struct Vec6 { S v[6]; };
template <class S> struct Mat3 { S m[9]; };   // (i, j) at 3 i + j
template <class S> struct Mat6 { S m[36]; };  // (i, j) at 6 i + j

// a NaN or an infinity gives x - x != 0; needs IEEE semantics (no fast-math)
template <class S>
RBDGRAD_HD bool is_finite(S x) { return x - x == S(0); }

// 1 / x, correctly rounded: the device's reciprocal instruction sequence is shorter than its
// division's
template <class S>
RBDGRAD_HD S reciprocal(S x) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(S) == sizeof(double)) return __drcp_rn(x);
  else return __frcp_rn(x);
#else
  return S(1) / x;
#endif
}

template <class S, int N>
RBDGRAD_HD void set_zero(S (&a)[N]) {
  for (int k = 0; k < N; ++k) a[k] = S(0);
}

// a x b for 3-vectors given as pointers (head or tail of a Vec6); out += when add
template <class S>
RBDGRAD_HD void cross3(const S* a, const S* b, S* out, bool add = false) {
  const S x = a[1] * b[2] - a[2] * b[1];
  const S y = a[2] * b[0] - a[0] * b[2];
  const S z = a[0] * b[1] - a[1] * b[0];
  if (add) {
    out[0] += x;
    out[1] += y;
    out[2] += z;
  } else {
    out[0] = x;
    out[1] = y;
    out[2] = z;
  }
}

// m1 x m2 (motion cross motion): [w1 x w2; w1 x v2 + v1 x w2]
template <class S>
RBDGRAD_HD Vec6<S> cross_motion(const Vec6<S>& m1, const Vec6<S>& m2) {
  Vec6<S> out;
  cross3(m1.v, m2.v, out.v);
  cross3(m1.v, m2.v + 3, out.v + 3);
  cross3(m1.v + 3, m2.v, out.v + 3, true);
  return out;
}

// m x* f (motion cross force): [w x n + v x f; w x f]
template <class S>
RBDGRAD_HD Vec6<S> cross_force(const Vec6<S>& m, const Vec6<S>& f) {
  Vec6<S> out;
  cross3(m.v, f.v, out.v);
  cross3(m.v + 3, f.v + 3, out.v, true);
  cross3(m.v, f.v + 3, out.v + 3);
  return out;
}

template <class S>
RBDGRAD_HD S dot(const Vec6<S>& a, const Vec6<S>& b) {
  S s = a.v[0] * b.v[0];
  for (int k = 1; k < 6; ++k) s += a.v[k] * b.v[k];
  return s;
}

template <class S>
RBDGRAD_HD Vec6<S> add(const Vec6<S>& a, const Vec6<S>& b) {
  Vec6<S> out;
  for (int k = 0; k < 6; ++k) out.v[k] = a.v[k] + b.v[k];
  return out;
}

template <class S>
RBDGRAD_HD Vec6<S> sub(const Vec6<S>& a, const Vec6<S>& b) {
  Vec6<S> out;
  for (int k = 0; k < 6; ++k) out.v[k] = a.v[k] - b.v[k];
  return out;
}

template <class S>
RBDGRAD_HD Vec6<S> scaled(const Vec6<S>& a, S s) {
  Vec6<S> out;
  for (int k = 0; k < 6; ++k) out.v[k] = a.v[k] * s;
  return out;
}

// y += a s
template <class S>
RBDGRAD_HD void add_scaled(Vec6<S>& y, const Vec6<S>& a, S s) {
  for (int k = 0; k < 6; ++k) y.v[k] += a.v[k] * s;
}

template <class S>
RBDGRAD_HD Vec6<S> mul(const Mat6<S>& A, const Vec6<S>& x) {
  Vec6<S> out;
  for (int i = 0; i < 6; ++i) {
    S s = A.m[6 * i] * x.v[0];
    for (int k = 1; k < 6; ++k) s += A.m[6 * i + k] * x.v[k];
    out.v[i] = s;
  }
  return out;
}

// A^T x
template <class S>
RBDGRAD_HD Vec6<S> mul_transposed(const Mat6<S>& A, const Vec6<S>& x) {
  Vec6<S> out;
  for (int j = 0; j < 6; ++j) {
    S s = A.m[j] * x.v[0];
    for (int k = 1; k < 6; ++k) s += A.m[6 * k + j] * x.v[k];
    out.v[j] = s;
  }
  return out;
}

template <class S>
RBDGRAD_HD Vec3<S> mul(const Mat3<S>& A, const S* x) {
  Vec3<S> out;
  for (int i = 0; i < 3; ++i) out.v[i] = A.m[3 * i] * x[0] + A.m[3 * i + 1] * x[1] + A.m[3 * i + 2] * x[2];
  return out;
}

template <class S>
RBDGRAD_HD Mat3<S> mul(const Mat3<S>& A, const Mat3<S>& B) {
  Mat3<S> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out.m[3 * i + j] = A.m[3 * i] * B.m[j] + A.m[3 * i + 1] * B.m[3 + j] + A.m[3 * i + 2] * B.m[6 + j];
  return out;
}

// A B^T
template <class S>
RBDGRAD_HD Mat3<S> mul_transposed(const Mat3<S>& A, const Mat3<S>& B) {
  Mat3<S> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out.m[3 * i + j] =
          A.m[3 * i] * B.m[3 * j] + A.m[3 * i + 1] * B.m[3 * j + 1] + A.m[3 * i + 2] * B.m[3 * j + 2];
  return out;
}

template <class S>
RBDGRAD_HD Mat3<S> skew(const S* v) {
  return Mat3<S>{{S(0), -v[2], v[1], v[2], S(0), -v[0], -v[1], v[0], S(0)}};
}

// Spatial inertia at the world origin of a body with mass m, centre of mass c and rotational
// inertia Ic about c, all in world axes: [[Ic - m cx cx, m cx], [-m cx, m 1]].
template <class S>
RBDGRAD_HD Mat6<S> spatial_inertia(S m, const Vec3<S>& c, const Mat3<S>& Ic) {
  const Mat3<S> cx = skew(c.v);
  const S mc[3] = {m * c.v[0], m * c.v[1], m * c.v[2]};
  const Mat3<S> mcx = skew(mc);
  const Mat3<S> mcxcx = mul(mcx, cx);
  Mat6<S> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      out.m[6 * i + j] = Ic.m[3 * i + j] - mcxcx.m[3 * i + j];
      out.m[6 * i + j + 3] = mcx.m[3 * i + j];
      out.m[6 * (i + 3) + j] = -mcx.m[3 * i + j];
      out.m[6 * (i + 3) + j + 3] = i == j ? m : S(0);
    }
  return out;
}

// Motion vector m about point A, re-expressed about point A + d: [w; v + w x d].
template <class S>
RBDGRAD_HD Vec6<S> shift_motion(const Vec6<S>& m, const S* d) {
  Vec6<S> out = m;
  cross3(m.v, d, out.v + 3, true);
  return out;
}

// Force vector f about point A, re-expressed about point A + d: [n - d x f; f].
template <class S>
RBDGRAD_HD Vec6<S> shift_force(const Vec6<S>& f, const S* d) {
  Vec6<S> out = f;
  cross3(f.v + 3, d, out.v, true);
  return out;
}

}  // namespace rbdgrad::cuda
