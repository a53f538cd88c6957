#include "rbdgrad/algorithm/rnea.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

namespace {

template <class S>
Status rnea_with(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                 const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, bool gravity, const S* fext,
                 const BodyMask* fext_bodies) {
  detail::NumericGuard<S> guard("rnea");
  // forward pass: velocities, accelerations, body forces; backward pass: subtree forces, tau = S . f
  detail::forward_pass<S, detail::Level::kDynamics>(model, ws, q.data(), qd.data(), qdd.data(), gravity);
  if (fext) detail::subtract_external_forces(model, ws, fext, fext_bodies);
  detail::backward_pass<S, detail::Level::kDynamics>(model, ws, &ws.tau, /*with_mass=*/false);
  return guard.finish(ws.tau);
}

}  // namespace

template <class S>
Status rnea(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
            const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, std::type_identity_t<const S*> fext) {
  return rnea_with(model, ws, q, qd, qdd, /*gravity=*/true, fext, nullptr);
}

template <class S>
Status rnea(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
            const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, const ExecutionPlan& plan,
            std::type_identity_t<const S*> fext) {
  // rnea never reads M^-1: only the plan's forces are checked
  if (Status s = check_plan(model.nv, plan, fext != nullptr, /*has_minv=*/plan.minv_supplied); !s) return s;
  const S* forces = plan.external_forces == ExternalForces::kNone ? nullptr : fext;
  return rnea_with(model, ws, q, qd, qdd, plan.gravity, forces, forced_bodies(plan));
}

#define RBDGRAD_INSTANTIATE(S)                                                                            \
  template Status rnea<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&,        \
                          const ConstVectorRef<S>&, const ConstVectorRef<S>&, std::type_identity_t<const S*>); \
  template Status rnea<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&,        \
                          const ConstVectorRef<S>&, const ConstVectorRef<S>&, const ExecutionPlan&, \
                          std::type_identity_t<const S*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
