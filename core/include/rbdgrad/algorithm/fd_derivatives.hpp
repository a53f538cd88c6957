// Analytical derivatives of forward dynamics (paper 000, Algorithm 3):
// dqdd/du = -M^-1 dc'/du with c' = RNEA(q, qd, qdd), u = q or qd.
#pragma once

#include "rbdgrad/algorithm/minverse.hpp"

namespace rbdgrad {

enum class InputKind : unsigned char {
  kTau,  // the input vector is tau: qdd = FD(q, qd, tau) is computed first
  kQdd,  // the input vector is qdd
};

/// \param[in] q, qd (dim model.nv)
/// \param[in] input tau or qdd (dim model.nv), as `kind` says
/// \param[in] fext as in rnea, or null
/// \param[in] supplied_minv optional M^-1(q) (nv x nv) from the caller, e.g. cached from the previous
///            MPC step (paper 000, footnote 1); then M^-1 is not computed and ws.Minv is not written.
/// \param[out] ws.qdd, ws.dqdd_dq, ws.dqdd_dqd, and ws.Minv when computed; on the way ws.M,
///             ws.tau (= c'), ws.dtau_dq, ws.dtau_dqd.
template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input,
                      InputKind kind, std::type_identity_t<const S*> fext = nullptr, std::type_identity_t<const MatrixX<S>*> supplied_minv = nullptr);

}  // namespace rbdgrad
