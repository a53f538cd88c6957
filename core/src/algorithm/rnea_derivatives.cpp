#include "rbdgrad/algorithm/rnea_derivatives.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <GradientStages kStages, class S>
Status rnea_derivatives_specialized(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                                    const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, bool gravity,
                                    std::type_identity_t<const S*> fext, const BodyMask* fext_bodies) {
  using detail::Level;
  // without derivative columns: tau and M
  constexpr Level kLevel = kStages.dq || kStages.dqd ? Level::kDerivatives : Level::kDynamics;
  detail::NumericGuard<S> guard("rnea_derivatives");
  // forward pass: motion, forces, alpha, beta, B; backward pass: composites, tau, M and the derivatives
  detail::forward_pass<S, kLevel, kStages.dq>(model, ws, q.data(), qd.data(), qdd.data(), gravity);
  if constexpr (kStages.fext) detail::subtract_external_forces(model, ws, fext, fext_bodies);
  detail::backward_pass<S, kLevel, kStages.dq, kStages.dqd>(model, ws, &ws.tau, /*with_mass=*/true);
  if constexpr (kStages.dq && kStages.dqd) return guard.finish(ws.tau, ws.dtau_dq, ws.dtau_dqd);
  else if constexpr (kStages.dq) return guard.finish(ws.tau, ws.dtau_dq);
  else if constexpr (kStages.dqd) return guard.finish(ws.tau, ws.dtau_dqd);
  else return guard.finish(ws.tau);
}

template <class S>
Status rnea_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd,
                        std::type_identity_t<const S*> fext) {
  constexpr GradientStages kNoForces{.fext = false};
  if (fext) return rnea_derivatives_specialized<kAllStages, S>(model, ws, q, qd, qdd, true, fext, nullptr);
  return rnea_derivatives_specialized<kNoForces, S>(model, ws, q, qd, qdd, true, nullptr, nullptr);
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status rnea_derivatives<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                      std::type_identity_t<const S*>);
#define RBDGRAD_INSTANTIATE_STAGES(S, I)                                                                       \
  template Status rnea_derivatives_specialized<stage_set(I), S>(                                               \
      const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, const ConstVectorRef<S>&,               \
      const ConstVectorRef<S>&, bool, std::type_identity_t<const S*>, const BodyMask*);
#define RBDGRAD_INSTANTIATE_ALL_STAGES(S) RBDGRAD_FOR_EACH_STAGE_SET(RBDGRAD_INSTANTIATE_STAGES, S)
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE_ALL_STAGES)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE_ALL_STAGES)

}  // namespace rbdgrad
