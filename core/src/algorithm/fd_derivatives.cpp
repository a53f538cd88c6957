#include "rbdgrad/algorithm/fd_derivatives.hpp"

#include <type_traits>

#include "articulated_body_pass.hpp"
#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {

template <GradientStages kStages, class S>
Status fd_derivatives_specialized(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                                  const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                                  bool gravity, std::type_identity_t<const S*> fext, const BodyMask* fext_bodies,
                                  std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  using detail::Level;
  // without derivative columns the passes stop at the dynamics: M^-1 and qdd only
  constexpr bool kAnyColumn = kStages.dq || kStages.dqd;
  constexpr Level kLevel = kAnyColumn ? Level::kDerivatives : Level::kDynamics;
  detail::NumericGuard<S> guard("fd_derivatives");
  bool factored = false;
  // M^-1 from the factors of the M that the backward pass left in ws.M, unless supplied
  auto inverse = [&]() -> Status {
    if (supplied_minv) return Status::ok();
    if (Status s = factorize_mass_matrix(model, ws); !s) return s;
    inverse_from_factors(model, ws);
    factored = true;
    return Status::ok();
  };
  // the external forces enter the body forces after the forward pass (not at all without the stage)
  auto body_forces = [&] {
    if constexpr (kStages.fext) detail::subtract_external_forces(model, ws, fext, fext_bodies);
  };
  // step 1 (Algorithm 3): RNEA quantities v', a', f'; step 2: the derivatives of c' = RNEA(q, qd, qdd)
  if (kind == InputKind::kQdd) {
    // the body forces serve d/dq only (and c', scratch here); without columns M alone is needed
    constexpr Level kQddLevel = kAnyColumn ? Level::kDerivatives : Level::kInertia;
    detail::forward_pass<S, kQddLevel, kStages.dq>(model, ws, q.data(), qd.data(), input.data(), gravity);
    if constexpr (kStages.dq) body_forces();
    detail::backward_pass<S, kQddLevel, kStages.dq, kStages.dqd>(model, ws, &ws.tau, /*with_mass=*/true);
    if (Status s = inverse(); !s) return s;
    ws.qdd = input;
  } else if constexpr (std::is_same_v<S, double>) {
    // tau input, f64: a first pass with qdd = 0 gives c, M and d tau/d qd (which does not depend
    // on qdd); qdd = M^-1 (tau - c) through the factors of M needed anyway (1e-13 accurate in f64,
    // cheaper than the articulated-body pass); then the qdd part of the motion and d tau/d q.
    detail::forward_pass<S, kLevel, kStages.dq>(model, ws, q.data(), qd.data(), nullptr, gravity);
    body_forces();
    // d/dq needs the final accelerations: its columns come after qdd
    detail::backward_pass<S, kLevel, /*kDq=*/false, kStages.dqd>(model, ws, &ws.tau, /*with_mass=*/true);
    if (Status s = inverse(); !s) return s;
    ws.qdd = input - ws.tau;
    if (factored) {
      solve_with_factors(model, ws, ws.qdd);
    } else {
      // through aba_u, free in this path, so that nothing allocates
      ws.aba_u.noalias() = *supplied_minv * ws.qdd;
      ws.qdd = ws.aba_u;
    }
    if constexpr (kStages.dq) {
      detail::add_acceleration_pass<S, /*kIntoBodyForce=*/false>(model, ws, ws.qdd.data(), gravity);
      detail::derivative_dq_pass(model, ws);
    }
    ws.tau = input;
  } else {
    // tau input, f32 and fixed point: M^-1 (tau - c) loses three digits in float, the
    // articulated-body pass about the joint points does not; it runs on the same velocities.
    // The body forces and the qdd part of the motion serve d/dq only (and c', scratch here).
    constexpr Level kBackward = kAnyColumn ? Level::kDerivatives : Level::kInertia;
    detail::forward_pass<S, kLevel, kStages.dq, /*kForAba=*/true>(model, ws, q.data(), qd.data(), nullptr, gravity);
    if constexpr (kStages.dq) body_forces();
    detail::articulated_body_pass<S, kStages.fext>(model, ws, qd.data(), input.data(), fext, fext_bodies, gravity,
                                                   ws.qdd.data());
    if constexpr (kStages.dq)
      detail::add_acceleration_pass<S, /*kIntoBodyForce=*/true>(model, ws, ws.qdd.data(), gravity);
    detail::backward_pass<S, kBackward, kStages.dq, kStages.dqd>(model, ws, &ws.tau, /*with_mass=*/true);
    if (Status s = inverse(); !s) return s;
  }
  const MatrixX<S>& Minv = supplied_minv ? *supplied_minv : ws.Minv;
  // step 3: dqdd/du = -M^-1 dc'/du, the columns asked for
  if constexpr (kStages.dq) multiply_by_minus_minv(model, Minv, ws.dtau_dq, ws.dqdd_dq);
  if constexpr (kStages.dqd) multiply_by_minus_minv(model, Minv, ws.dtau_dqd, ws.dqdd_dqd);
  auto finish = [&](const auto&... columns) {
    return factored ? guard.finish(ws.qdd, ws.Minv, columns...) : guard.finish(ws.qdd, columns...);
  };
  if constexpr (kStages.dq && kStages.dqd) return finish(ws.dqdd_dq, ws.dqdd_dqd);
  else if constexpr (kStages.dq) return finish(ws.dqdd_dq);
  else if constexpr (kStages.dqd) return finish(ws.dqdd_dqd);
  else return finish();
}

template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input,
                      InputKind kind, std::type_identity_t<const S*> fext,
                      std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  // every stage, with the model's gravity and forces on every body when given
  constexpr GradientStages kNoForces{.fext = false};
  if (fext)
    return fd_derivatives_specialized<kAllStages, S>(model, ws, q, qd, input, kind, true, fext, nullptr, supplied_minv);
  return fd_derivatives_specialized<kNoForces, S>(model, ws, q, qd, input, kind, true, nullptr, nullptr, supplied_minv);
}

template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                      const ExecutionPlan& plan, std::type_identity_t<const S*> fext,
                      std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  if (Status s = check_plan(model.nv, plan, fext != nullptr, supplied_minv != nullptr); !s) return s;
  const MatrixX<S>* minv = plan.minv_supplied ? supplied_minv : nullptr;
  return dispatch_stages(gradient_stages(plan), [&]<GradientStages kStages>() {
    return fd_derivatives_specialized<kStages, S>(model, ws, q, qd, input, kind, plan.gravity, fext,
                                                  forced_bodies(plan), minv);
  });
}

#define RBDGRAD_INSTANTIATE_FD(S)                                                                  \
  template Status fd_derivatives<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                    const ConstVectorRef<S>&, const ConstVectorRef<S>&,            \
                                    InputKind, std::type_identity_t<const S*>,                     \
                                    std::type_identity_t<const MatrixX<S>*>);
#define RBDGRAD_INSTANTIATE_STAGES(S, I)                                                                      \
  template Status fd_derivatives_specialized<stage_set(I), S>(                                                \
      const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, const ConstVectorRef<S>&,              \
      const ConstVectorRef<S>&, InputKind, bool, std::type_identity_t<const S*>, const BodyMask*,             \
      std::type_identity_t<const MatrixX<S>*>);
#define RBDGRAD_INSTANTIATE_PLAN(S)                                                                \
  template Status fd_derivatives<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                    const ConstVectorRef<S>&, const ConstVectorRef<S>&, InputKind,  \
                                    const ExecutionPlan&, std::type_identity_t<const S*>,           \
                                    std::type_identity_t<const MatrixX<S>*>);                       \
  RBDGRAD_FOR_EACH_STAGE_SET(RBDGRAD_INSTANTIATE_STAGES, S)
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE_FD)
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE_PLAN)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE_FD)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE_PLAN)

}  // namespace rbdgrad
