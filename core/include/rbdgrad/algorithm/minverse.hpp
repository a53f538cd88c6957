// The inverse mass matrix through the tree-sparse factorization M = L^T D L (Featherstone, RBDA
// section 6.5): L has nonzeros only at (i, ancestor of i), so factorizing costs O(n d^2) and the
// inverse O(sum of subtree sizes squared), never a dense general inverse.
#pragma once

#include "rbdgrad/algorithm/crba.hpp"

namespace rbdgrad {

/// Factorizes ws.M (as left by crba) into ws.L, ws.D, ws.Dinv.
/// Fails with failed_precondition naming the joint when M is not positive definite there.
template <class S>
Status factorize_mass_matrix(const ModelTpl<S>& model, WorkspaceTpl<S>& ws);

/// ws.Minv from the factors of factorize_mass_matrix (also fills ws.Linv).
template <class S>
void inverse_from_factors(const ModelTpl<S>& model, WorkspaceTpl<S>& ws);

/// out = -Minv * dtau for a derivative of inverse dynamics (nv x nv), skipping the entries that the
/// tree makes zero: column j of dtau is nonzero only on the ancestors and the subtree of joint j.
template <class S>
void multiply_by_minus_minv(const ModelTpl<S>& model, const MatrixX<S>& Minv, const MatrixX<S>& dtau,
                            MatrixX<S>& out);

/// Solves M x = b in place with the factors of factorize_mass_matrix, O(n d).
template <class S>
void solve_with_factors(const ModelTpl<S>& model, const WorkspaceTpl<S>& ws, VectorX<S>& b);

/// M^-1(q): crba, factorize, invert.
/// \param[in] q joint positions (dim model.nv)
/// \param[out] ws.M, ws.Minv (nv x nv, symmetric)
template <class S>
Status minverse(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q);

}  // namespace rbdgrad
