#include "rbdgrad/algorithm/rnea_derivatives.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <class S>
Status rnea_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd,
                        std::type_identity_t<const S*> fext) {
  detail::NumericGuard<S> guard("rnea_derivatives");
  // forward pass: motion, forces, alpha, beta, B; backward pass: composites, tau, M and both derivatives
  detail::forward_pass<S, detail::Level::kDerivatives>(model, ws, q.data(), qd.data(), qdd.data(), fext);
  detail::backward_pass<S, detail::Level::kDerivatives>(model, ws, &ws.tau, /*with_mass=*/true, /*with_dq=*/true);
  return guard.finish(ws.tau, ws.dtau_dq, ws.dtau_dqd);
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status rnea_derivatives<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                      std::type_identity_t<const S*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
