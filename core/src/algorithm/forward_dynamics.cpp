#include "rbdgrad/algorithm/forward_dynamics.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "articulated_body_pass.hpp"

namespace rbdgrad {

namespace {

template <class S>
Status forward_dynamics_with(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                             const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau, bool gravity,
                             const S* fext, const BodyMask* fext_bodies) {
  detail::NumericGuard<S> guard("forward_dynamics");
  // forward pass: velocities and bias terms; then the articulated-body recursion, with or without
  // its external-force stage
  detail::forward_pass<S, detail::Level::kDynamics, /*kBeta=*/true, /*kForAba=*/true>(model, ws, q.data(), qd.data(),
                                                                                  nullptr, gravity);
  if (fext)
    detail::articulated_body_pass<S, true>(model, ws, qd.data(), tau.data(), fext, fext_bodies, gravity, ws.qdd.data());
  else
    detail::articulated_body_pass<S, false>(model, ws, qd.data(), tau.data(), nullptr, nullptr, gravity, ws.qdd.data());
  return guard.finish(ws.qdd);
}

}  // namespace

template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau,
                        std::type_identity_t<const S*> fext) {
  return forward_dynamics_with(model, ws, q, qd, tau, /*gravity=*/true, fext, nullptr);
}

template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau, const ExecutionPlan& plan,
                        std::type_identity_t<const S*> fext) {
  // forward dynamics never reads M^-1: only the plan's forces are checked
  if (Status s = check_plan(model.nv, plan, fext != nullptr, /*has_minv=*/plan.minv_supplied); !s) return s;
  const S* forces = plan.external_forces == ExternalForces::kNone ? nullptr : fext;
  return forward_dynamics_with(model, ws, q, qd, tau, plan.gravity, forces, forced_bodies(plan));
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status forward_dynamics<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                      std::type_identity_t<const S*>);                                \
  template Status forward_dynamics<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&,             \
                                      const ExecutionPlan&, std::type_identity_t<const S*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
