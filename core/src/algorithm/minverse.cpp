#include "rbdgrad/algorithm/minverse.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {

template <class S>
Status factorize_mass_matrix(const ModelTpl<S>& model, WorkspaceTpl<S>& ws) {
  const int n = model.nv;
  const std::vector<int>& parent = model.parent;
  MatrixX<S>& L = ws.L;
  // only entries (i, ancestor-or-self of i) are read and written
  for (int i = 0; i < n; ++i)
    for (int j = i; j >= 0; j = parent[j]) L(i, j) = ws.M(i, j);
  // leaves first: eliminate joint k from its ancestors (RBDA table 6.3)
  for (int k = n - 1; k >= 0; --k) {
    const S d = L(k, k);
    if constexpr (!is_fixed_point_v<S>) {
      using std::isfinite;
      if (!isfinite(d))
        return out_of_range("mass matrix is not finite at joint " + std::to_string(k) + " ('" + model.joints[k].name +
                            "'): non-finite input or overflow");
    }
    if (!(d > S(0)))
      return failed_precondition("mass matrix is not positive definite at joint " + std::to_string(k) + " ('" +
                                 model.joints[k].name + "'): it moves no inertia in this configuration");
    for (int i = parent[k]; i >= 0; i = parent[i]) {
      const S a = L(k, i) / d;
      for (int j = i; j >= 0; j = parent[j]) L(i, j) -= a * L(k, j);
      L(k, i) = a;
    }
    ws.D(k) = d;
    ws.Dinv(k) = S(1) / d;
  }
  return Status::ok();
}

template <class S>
void inverse_from_factors(const ModelTpl<S>& model, WorkspaceTpl<S>& ws) {
  const int n = model.nv;
  const std::vector<int>& parent = model.parent;
  const MatrixX<S>& L = ws.L;
  MatrixX<S>& Linv = ws.Linv;
  // L^-1 keeps the ancestor sparsity of L: Linv(a, b) = -sum over b <= m < a of L(a, m) Linv(m, b)
  for (int a = 0; a < n; ++a) {
    Linv(a, a) = S(1);
    for (int b = parent[a]; b >= 0; b = parent[b]) {
      S s = -L(a, b);
      for (int m = parent[a]; m != b; m = parent[m]) s -= L(a, m) * Linv(m, b);
      Linv(a, b) = s;
    }
  }
  // M^-1 = L^-1 D^-1 L^-T: joint k adds a rank-one term on its subtree block (a contiguous
  // range); lower triangle first, then mirrored
  MatrixX<S>& Minv = ws.Minv;
  Minv.setZero();
  for (int k = 0; k < n; ++k) {
    const int end = model.subtree_end[k];
    for (int b = k; b < end; ++b) {
      const S lb = Linv(b, k) * ws.Dinv(k);
      for (int a = b; a < end; ++a) Minv(a, b) += Linv(a, k) * lb;
    }
  }
  for (int b = 0; b < n; ++b)
    for (int a = b + 1; a < n; ++a) Minv(b, a) = Minv(a, b);
}

template <class S>
void multiply_by_minus_minv(const ModelTpl<S>& model, const MatrixX<S>& Minv, const MatrixX<S>& dtau,
                            MatrixX<S>& out) {
  // column j of d tau/d u is nonzero only on the ancestors of j and the subtree of j. A chain has
  // no zeros to skip and Eigen's matrix product is faster there; branchy trees use plain loops.
  const int n = model.nv;
  long nonzeros = 0;
  for (int j = 0; j < n; ++j) nonzeros += model.subtree_end[j] - j + model.depth[j] - 1;
  if (2 * nonzeros > static_cast<long>(n) * n) {
    out.noalias() = -Minv * dtau;
    return;
  }
  const S* __restrict minv = Minv.data();
  for (int j = 0; j < n; ++j) {
    S* __restrict col = out.data() + static_cast<std::ptrdiff_t>(j) * n;
    const S* __restrict d = dtau.data() + static_cast<std::ptrdiff_t>(j) * n;
    for (int a = 0; a < n; ++a) col[a] = S(0);
    const int end = model.subtree_end[j];
    for (int r = j; r < end; ++r) {
      const S c = d[r];
      const S* __restrict m = minv + static_cast<std::ptrdiff_t>(r) * n;
      for (int a = 0; a < n; ++a) col[a] -= m[a] * c;
    }
    for (int r = model.parent[j]; r >= 0; r = model.parent[r]) {
      const S c = d[r];
      const S* __restrict m = minv + static_cast<std::ptrdiff_t>(r) * n;
      for (int a = 0; a < n; ++a) col[a] -= m[a] * c;
    }
  }
}

template <class S>
void solve_with_factors(const ModelTpl<S>& model, const WorkspaceTpl<S>& ws, VectorX<S>& b) {
  const int n = model.nv;
  const std::vector<int>& parent = model.parent;
  // L^T z = b, leaves first
  for (int k = n - 1; k >= 0; --k)
    for (int i = parent[k]; i >= 0; i = parent[i]) b(i) -= ws.L(k, i) * b(k);
  for (int k = 0; k < n; ++k) b(k) *= ws.Dinv(k);
  // L x = z, root first
  for (int i = 0; i < n; ++i)
    for (int m = parent[i]; m >= 0; m = parent[m]) b(i) -= ws.L(i, m) * b(m);
}

template <class S>
Status minverse(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q) {
  detail::NumericGuard<S> guard("minverse");
  if (Status s = crba(model, ws, q); !s) return s;
  if (Status s = factorize_mass_matrix(model, ws); !s) return s;
  inverse_from_factors(model, ws);
  return guard.finish(ws.Minv);
}

#define RBDGRAD_INSTANTIATE(S)                                                                            \
  template Status factorize_mass_matrix<S>(const ModelTpl<S>&, WorkspaceTpl<S>&);                          \
  template void inverse_from_factors<S>(const ModelTpl<S>&, WorkspaceTpl<S>&);                             \
  template void multiply_by_minus_minv<S>(const ModelTpl<S>&, const MatrixX<S>&, const MatrixX<S>&, MatrixX<S>&); \
  template void solve_with_factors<S>(const ModelTpl<S>&, const WorkspaceTpl<S>&, VectorX<S>&);            \
  template Status minverse<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
