// A spatial inertia at the world origin by its parameters, as the block kernel's lean working set
// keeps them (block_workspace.hpp): I = [J, h x; -h x, m 1] with J the rotational inertia about
// the origin and h = m c the first moment. Nine scalars a body (h, then J's upper triangle); the
// mass is not stored (the model's, or the subtree's, or zero for a rate), where the upper triangle
// of the 6x6 matrix takes 21. The rate of an inertia moving with spatial velocity v,
// v x* I - I v x, has the same form with zero mass: its parameters are h' = w x h + m v_o and
// J' = w x J - J w x - (h v_o^T + v_o h^T) + 2 (v_o . h) 1 (v = [w; v_o]).
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

// Scalars from one body's parameters to the next: 9, odd, so that the lanes of a warp that take
// the same parameter of consecutive bodies hit different shared-memory banks. (An enumerator: NVRTC
// emits an inline constexpr variable as a global, even in kernels that do not use it.)
enum : int { kInertiaParameterStride = 9 };
// where J(r, c) (r, c < 3) sits among a body's parameters: after h, its upper triangle row by row
RBDGRAD_HD constexpr int inertia_j_index(int r, int c) {
  return r <= c ? 3 + r * 3 - r * (r - 1) / 2 + (c - r) : 3 + c * 3 - c * (c - 1) / 2 + (r - c);
}

namespace block {

// (P x)_c of the inertia whose parameters are body i's of `base` and whose mass is `mass`
// (kWithMass; a rate's mass is zero, and its product skips the term)
template <bool kWithMass, class S>
RBDGRAD_HD S parameter_row_dot(const S* base, int i, int c, const S* x, S mass) {
  const S* P = base + kInertiaParameterStride * i;
  const S* h = P;
  if (c < 3) {
    // J w + h x v_o
    const int c1 = c == 2 ? 0 : c + 1, c2 = c == 0 ? 2 : c - 1;
    return P[inertia_j_index(c, 0)] * x[0] + P[inertia_j_index(c, 1)] * x[1] + P[inertia_j_index(c, 2)] * x[2] +
           (h[c1] * x[3 + c2] - h[c2] * x[3 + c1]);
  }
  // m v_o - h x w
  const int r = c - 3, r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  const S cross = h[r2] * x[r1] - h[r1] * x[r2];
  if constexpr (kWithMass) return mass * x[c] + cross;
  else return cross;
}
template <class S>
RBDGRAD_HD S inertia_row_dot(const S* base, int i, int c, const S* x, S mass) {
  return parameter_row_dot<true>(base, i, c, x, mass);
}
template <class S>
RBDGRAD_HD S rate_row_dot(const S* base, int i, int c, const S* x) {
  return parameter_row_dot<false>(base, i, c, x, S(0));
}

// Parameter e (0..8) of the rate of body i's inertia (parameters P, mass `mass`) moving with the
// spatial velocity v, by the formulas above
template <class S>
RBDGRAD_HD S inertia_rate_parameter(const S* P, S mass, const S* v, int e) {
  const S* w = v;
  const S* vo = v + 3;
  const S* h = P;
  if (e < 3) {
    const int e1 = e == 2 ? 0 : e + 1, e2 = e == 0 ? 2 : e - 1;
    return (w[e1] * h[e2] - w[e2] * h[e1]) + mass * vo[e];
  }
  // (r, k) of J's upper triangle
  const int r = e < 6 ? 0 : e < 8 ? 1 : 2, k = e < 6 ? e - 3 : e < 8 ? e - 5 : 2;
  // (w x J)(a, b) = w[a1] J(a2, b) - w[a2] J(a1, b)
  auto wxJ = [&](int a, int b) {
    const int a1 = a == 2 ? 0 : a + 1, a2 = a == 0 ? 2 : a - 1;
    return w[a1] * P[inertia_j_index(a2, b)] - w[a2] * P[inertia_j_index(a1, b)];
  };
  S value = wxJ(r, k) + wxJ(k, r) - (h[r] * vo[k] + vo[r] * h[k]);
  if (r == k) value += S(2) * (vo[0] * h[0] + vo[1] * h[1] + vo[2] * h[2]);
  return value;
}

}  // namespace block
}  // namespace rbdgrad::cuda
