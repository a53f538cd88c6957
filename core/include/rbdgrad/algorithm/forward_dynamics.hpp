// Forward dynamics qdd = ABA(q, qd, tau) (paper 000, equation 1, first form): O(n), and in float far
// more accurate than M^-1 (tau - c) (about 1e-7 against 1e-5 relative on the shipped robots).
#pragma once

#include "rbdgrad/algorithm/minverse.hpp"

namespace rbdgrad {

/// qdd = FD(q, qd, tau, fext).
/// \param[in] q, qd, tau (dim model.nv); fext as in rnea.
/// \param[out] ws.qdd (dim nv)
template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau,
                        std::type_identity_t<const S*> fext = nullptr);

/// The same under an execution plan: its gravity and external forces, as rnea with a plan.
template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau, const ExecutionPlan& plan,
                        std::type_identity_t<const S*> fext);

}  // namespace rbdgrad
