#include "rbdgrad/algorithm/forward_dynamics.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "articulated_body_pass.hpp"

namespace rbdgrad {

template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau,
                        std::type_identity_t<const S*> fext) {
  detail::NumericGuard<S> guard("forward_dynamics");
  // forward pass: velocities and bias terms; then the articulated-body recursion
  detail::forward_pass<S, detail::Level::kDynamics, /*kForAba=*/true>(model, ws, q.data(), qd.data(), nullptr, fext);
  detail::articulated_body_pass(model, ws, qd.data(), tau.data(), fext, ws.qdd.data());
  return guard.finish(ws.qdd);
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status forward_dynamics<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                      std::type_identity_t<const S*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
