// A spatial inertia at the world origin by its parameters, as the block kernel's lean working set
// keeps them (block_workspace.hpp): I = [J, h x; -h x, m 1] with J the rotational inertia about
// the origin and h = m c the first moment. Nine scalars a body (h, then J's upper triangle); the
// mass is not stored (the model's, or the subtree's, or zero for a rate), where the upper triangle
// of the 6x6 matrix takes 21. The rate of an inertia moving with spatial velocity v,
// v x* I - I v x, has the same form with zero mass: its parameters are h' = w x h + m v_o and
// J' = w x J - J w x - (h v_o^T + v_o h^T) + 2 (v_o . h) 1 (v = [w; v_o]).
#pragma once

#include "scalar_pairs.hpp"
#include "spatial.hpp"

namespace rbdgrad::cuda {

// Scalars from one body's parameters to the next: 9, odd, so that the lanes of a warp that take
// the same parameter of consecutive bodies hit different shared-memory banks. (An enumerator: NVRTC
// emits an inline constexpr variable as a global, even in kernels that do not use it.)
enum : int { kInertiaParameterStride = 9 };
// Where J(r, c) (r, c < 3) sits among a body's parameters: after h, its upper triangle row by row
// (3 + 0 1 2 / 1 3 4 / 2 4 5). By a table of 3-bit fields, field 3 r + c: the products take r at
// run time, and the table is a shift and a mask where the triangle's arithmetic took about six
// instructions an index.
enum : unsigned {
  kInertiaJIndexTable = 0u | 1u << 3 | 2u << 6 | 1u << 9 | 3u << 12 | 4u << 15 | 2u << 18 | 4u << 21 | 5u << 24
};
RBDGRAD_HD constexpr int inertia_j_index(int r, int c) {
  return 3 + static_cast<int>((kInertiaJIndexTable >> (3 * (3 * r + c))) & 7u);
}

namespace block {

// (P x)_c of the inertia whose parameters are body i's of `base` and whose mass is `mass`
// (kWithMass; a rate's mass is zero, and its product skips the term). Both halves' terms and a
// select, as block_fused_state.hpp's cross products: J w + h x v_o for c < 3, m v_o - h x w for
// c = 3 + r (row r of J read there too, and not used).
template <bool kWithMass, class S>
RBDGRAD_HD S parameter_row_dot(const S* base, int i, int c, const S* x, S mass) {
  const S* P = base + kInertiaParameterStride * i;
  const S* h = P;
  const bool angular = c < 3;
  const int r = angular ? c : c - 3, r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  // the cross product's term: h[r1] x_o[r2] - h[r2] x_o[r1] (J w + h x v_o), else h[r2] w[r1] -
  // h[r1] w[r2] (- h x w)
  const S cross = h[angular ? r1 : r2] * x[angular ? 3 + r2 : r1] - h[angular ? r2 : r1] * x[angular ? 3 + r1 : r2];
  const S moment =
      P[inertia_j_index(r, 0)] * x[0] + P[inertia_j_index(r, 1)] * x[1] + P[inertia_j_index(r, 2)] * x[2] + cross;
  if constexpr (kWithMass) return angular ? moment : mass * x[c] + cross;
  else return angular ? moment : cross;
}
// Rows r and 3 + r (r < 3) of the product above at once, for an item that takes both: the terms
// each row's select keeps, and the loads they share (h, x) once. kWhole: x (aligned to pairs, the
// lean layout's 6-vectors) read whole, three 16-byte loads that a body's lanes share, its
// components picked by selects; read a component a load, the three lanes of a body met the
// banks three ways where two would do, and x took eight loads.
template <bool kWithMass, bool kWhole = false, class S>
RBDGRAD_HD void parameter_rows_dot(const S* base, int i, int r, const S* x, S mass, S& angular, S& linear) {
  const S* P = base + kInertiaParameterStride * i;
  const S* h = P;
  const int r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  const S h1 = h[r1], h2 = h[r2];
  if constexpr (kWhole) {
    S v[6];
    load_six<true>(x, v);
    const S w1 = pick3(v[0], v[1], v[2], r1), w2 = pick3(v[0], v[1], v[2], r2);
    const S o1 = pick3(v[3], v[4], v[5], r1), o2 = pick3(v[3], v[4], v[5], r2), o = pick3(v[3], v[4], v[5], r);
    angular = P[inertia_j_index(r, 0)] * v[0] + P[inertia_j_index(r, 1)] * v[1] + P[inertia_j_index(r, 2)] * v[2] +
              (h1 * o2 - h2 * o1);
    const S cross = h2 * w1 - h1 * w2;
    if constexpr (kWithMass) linear = mass * o + cross;
    else linear = cross;
  } else {
    angular = P[inertia_j_index(r, 0)] * x[0] + P[inertia_j_index(r, 1)] * x[1] + P[inertia_j_index(r, 2)] * x[2] +
              (h1 * x[3 + r2] - h2 * x[3 + r1]);
    const S cross = h2 * x[r1] - h1 * x[r2];
    if constexpr (kWithMass) linear = mass * x[3 + r] + cross;
    else linear = cross;
  }
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
