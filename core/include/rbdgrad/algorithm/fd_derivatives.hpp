// Analytical derivatives of forward dynamics (paper 000, Algorithm 3):
// dqdd/du = -M^-1 dc'/du with c' = RNEA(q, qd, qdd), u = q or qd.
#pragma once

#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/execution_plan.hpp"

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

/// The same with only the stages `plan` keeps (ExecutionPlan): the d/dq or d/dqd columns, gravity,
/// the external forces (on the plan's bodies only: the others' fext is never read), M^-1 from the
/// caller. Selects fd_derivatives_specialized once per call.
/// \param[in] fext read when plan.external_forces is not kNone (then not null)
/// \param[in] supplied_minv used when plan.minv_supplied (then not null)
/// \param[out] ws.qdd, ws.dqdd_dq when plan.dqdd_dq, ws.dqdd_dqd when plan.dqdd_dqd, ws.Minv when
///             computed; no other output is written. On the way ws.M; ws.tau, ws.dtau_dq and
///             ws.dtau_dqd are scratch.
/// Errors: invalid_argument when the plan does not fit the model or the data (check_plan).
template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                      const ExecutionPlan& plan, std::type_identity_t<const S*> fext,
                      std::type_identity_t<const MatrixX<S>*> supplied_minv);

/// One specialized instantiation: fd_derivatives compiled with the stages of kStages only (without
/// kStages.dq, no code for the d/dq columns exists in it, ...). The plan overload calls it; call it
/// directly when the stages are known at compile time.
/// \param[in] gravity false: as if the model's gravity were zero
/// \param[in] fext read when kStages.fext (then not null): every body, or those of fext_bodies
///            when not null
/// \param[in] supplied_minv as in fd_derivatives
/// \param[out] as the plan overload, for the columns kStages keeps.
template <GradientStages kStages, class S>
Status fd_derivatives_specialized(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                                  const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                                  bool gravity, std::type_identity_t<const S*> fext, const BodyMask* fext_bodies,
                                  std::type_identity_t<const MatrixX<S>*> supplied_minv);

}  // namespace rbdgrad
