#include "rbdgrad/algorithm/rnea.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <class S>
Status rnea(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
            const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, std::type_identity_t<const S*> fext) {
  detail::NumericGuard<S> guard("rnea");
  // forward pass: velocities, accelerations, body forces; backward pass: subtree forces, tau = S . f
  detail::forward_pass<S, detail::Level::kDynamics>(model, ws, q.data(), qd.data(), qdd.data(), fext);
  detail::backward_pass<S, detail::Level::kDynamics>(model, ws, &ws.tau, /*with_mass=*/false, /*with_dq=*/false);
  return guard.finish(ws.tau);
}

#define RBDGRAD_INSTANTIATE(S)                                                                            \
  template Status rnea<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&,        \
                          const ConstVectorRef<S>&, const ConstVectorRef<S>&, std::type_identity_t<const S*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
