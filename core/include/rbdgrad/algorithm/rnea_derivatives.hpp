// Analytical derivatives of inverse dynamics (paper 000, Algorithm 2), in world-frame O(n d) form.
#pragma once

#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad {

/// d tau / d q and d tau / d qd of tau = ID(q, qd, qdd, fext). External forces are held fixed in
/// their link frames when q varies.
/// \param[in] q, qd, qdd (dim model.nv); fext as in rnea.
/// \param[out] ws.tau (dim nv), ws.dtau_dq, ws.dtau_dqd (nv x nv: row i = tau_i, column j = q_j),
///             and ws.M, which the same passes produce.
template <class S>
Status rnea_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd,
                        std::type_identity_t<const S*> fext = nullptr);

/// One specialized instantiation (GradientStages): only the columns kStages keeps (ws.dtau_dq when
/// kStages.dq, ws.dtau_dqd when kStages.dqd; the other is not written), and the external forces
/// only with kStages.fext. evaluate_outputs selects it from the requested outputs and its plan.
/// \param[in] gravity false: as if the model's gravity were zero
/// \param[in] fext read when kStages.fext (then not null): every body, or those of fext_bodies
///            when not null
/// \param[out] ws.tau, ws.M, and the kept columns.
template <GradientStages kStages, class S>
Status rnea_derivatives_specialized(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                                    const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, bool gravity,
                                    std::type_identity_t<const S*> fext, const BodyMask* fext_bodies);

}  // namespace rbdgrad
