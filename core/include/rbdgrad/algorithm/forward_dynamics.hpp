// Forward dynamics qdd = M^-1 (tau - c) (paper 000, equation 1, second form).
#pragma once

#include "rbdgrad/algorithm/minverse.hpp"

namespace rbdgrad {

/// qdd = FD(q, qd, tau, fext).
/// \param[in] q, qd, tau (dim model.nv); fext as in rnea.
/// \param[out] ws.qdd (dim nv); also ws.bias = c(q, qd) and ws.M with its factors.
template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau,
                        const S* fext = nullptr);

}  // namespace rbdgrad
