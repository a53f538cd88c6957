// M^-1 through the tree-sparse factorization M = L^T D L, and the products with it, ported from
// core/src/algorithm/minverse.cpp: L has nonzeros only at (i, ancestor of i), so nothing is a
// dense general inverse.
#pragma once

#include "state_status.hpp"
#include "model_view.hpp"
#include "workspace_view.hpp"

namespace rbdgrad::cuda {

// Factorizes ws.M into ws.L, ws.D, ws.Dinv. Returns 0, or the status of the joint where M is not
// finite or not positive definite.
template <class S>
RBDGRAD_HD std::uint32_t factorize_mass_matrix(const ModelView<S>& m, const WorkspaceView<S>& ws) {
  const int n = m.nv;
  // only entries (i, ancestor-or-self of i) are read and written
  for (int i = 0; i < n; ++i)
    for (int j = i; j >= 0; j = m.parent[j]) ws.L(i, j) = ws.M(i, j);
  // leaves first: eliminate joint k from its ancestors (RBDA table 6.3)
  for (int k = n - 1; k >= 0; --k) {
    const S d = ws.L(k, k);
    if (!is_finite(d)) return state_status(Reason::kMassNotFinite, Algorithm::kNone, k);
    if (!(d > S(0))) return state_status(Reason::kMassNotPositive, Algorithm::kNone, k);
    for (int i = m.parent[k]; i >= 0; i = m.parent[i]) {
      const S a = ws.L(k, i) / d;
      for (int j = i; j >= 0; j = m.parent[j]) ws.L(i, j) -= a * ws.L(k, j);
      ws.L(k, i) = a;
    }
    ws.D[k] = d;
    ws.Dinv[k] = S(1) / d;
  }
  return 0;
}

// ws.Minv (full, symmetric) from the factors; also fills ws.Linv.
template <class S>
RBDGRAD_HD void inverse_from_factors(const ModelView<S>& m, const WorkspaceView<S>& ws) {
  const int n = m.nv;
  // L^-1 keeps the ancestor sparsity of L: Linv(a, b) = -sum over b <= k < a of L(a, k) Linv(k, b)
  for (int a = 0; a < n; ++a) {
    ws.Linv(a, a) = S(1);
    for (int b = m.parent[a]; b >= 0; b = m.parent[b]) {
      S s = -ws.L(a, b);
      for (int k = m.parent[a]; k != b; k = m.parent[k]) s -= ws.L(a, k) * ws.Linv(k, b);
      ws.Linv(a, b) = s;
    }
  }
  // M^-1 = L^-1 D^-1 L^-T: joint k adds a rank-one term on its subtree block (a contiguous
  // range); lower triangle first, then mirrored
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) ws.Minv(a, b) = S(0);
  for (int k = 0; k < n; ++k) {
    const int end = m.subtree_end[k];
    for (int b = k; b < end; ++b) {
      const S lb = ws.Linv(b, k) * ws.Dinv[k];
      for (int a = b; a < end; ++a) ws.Minv(a, b) += ws.Linv(a, k) * lb;
    }
  }
  for (int b = 0; b < n; ++b)
    for (int a = b + 1; a < n; ++a) ws.Minv(b, a) = ws.Minv(a, b);
}

// out = -Minv dtau for a derivative of inverse dynamics (nv x nv): column j of dtau is nonzero
// only on the ancestors and the subtree of joint j. Minv is the workspace's or the caller's.
template <class S, class MinvMatrix>
RBDGRAD_HD void multiply_by_minus_minv(const ModelView<S>& m, const MinvMatrix& Minv, const StridedMatrix<S>& dtau,
                                       const StridedMatrix<S>& out) {
  const int n = m.nv;
  for (int j = 0; j < n; ++j) {
    for (int a = 0; a < n; ++a) out(a, j) = S(0);
    const int end = m.subtree_end[j];
    for (int r = j; r < end; ++r) {
      const S c = dtau(r, j);
      for (int a = 0; a < n; ++a) out(a, j) -= Minv(a, r) * c;
    }
    for (int r = m.parent[j]; r >= 0; r = m.parent[r]) {
      const S c = dtau(r, j);
      for (int a = 0; a < n; ++a) out(a, j) -= Minv(a, r) * c;
    }
  }
}

// Solves M x = b in place (b = a vector field of nv) with the factors, O(n d).
template <class S>
RBDGRAD_HD void solve_with_factors(const ModelView<S>& m, const WorkspaceView<S>& ws, const Strided<S>& b) {
  const int n = m.nv;
  // L^T z = b, leaves first
  for (int k = n - 1; k >= 0; --k)
    for (int i = m.parent[k]; i >= 0; i = m.parent[i]) b[i] -= ws.L(k, i) * b[k];
  for (int k = 0; k < n; ++k) b[k] *= ws.Dinv[k];
  // L x = z, root first
  for (int i = 0; i < n; ++i)
    for (int k = m.parent[i]; k >= 0; k = m.parent[k]) b[i] -= ws.L(i, k) * b[k];
}

}  // namespace rbdgrad::cuda
