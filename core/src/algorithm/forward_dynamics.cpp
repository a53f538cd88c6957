#include "rbdgrad/algorithm/forward_dynamics.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <class S>
Status forward_dynamics(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& tau,
                        const S* fext) {
  detail::NumericGuard<S> guard("forward_dynamics");
  // c = RNEA(q, qd, 0) and M in one pair of passes
  detail::forward_pass<S, detail::Level::kDynamics>(model, ws, q.data(), qd.data(), nullptr, fext);
  detail::backward_pass<S, detail::Level::kDynamics>(model, ws, &ws.bias, /*with_mass=*/true, /*with_dq=*/false);
  if (Status s = factorize_mass_matrix(model, ws); !s) return s;
  // qdd = M^-1 (tau - c) through the sparse factors
  ws.qdd = tau - ws.bias;
  solve_with_factors(model, ws, ws.qdd);
  return guard.finish(ws.qdd);
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status forward_dynamics<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                      const S*);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
