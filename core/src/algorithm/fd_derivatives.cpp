#include "rbdgrad/algorithm/fd_derivatives.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input,
                      InputKind kind, std::type_identity_t<const S*> fext,
                      std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  using detail::Level;
  detail::NumericGuard<S> guard("fd_derivatives");
  const bool tau_input = kind == InputKind::kTau;
  // step 1 (Algorithm 3): RNEA quantities v', a', f'. With tau as input, qdd is found first by the
  // articulated-body recursion on the same velocities (accurate in float), then added in.
  detail::forward_pass<S, Level::kDerivatives>(model, ws, q.data(), qd.data(), tau_input ? nullptr : input.data(),
                                               fext);
  if (tau_input) {
    detail::articulated_body_pass(model, ws, qd.data(), input.data(), fext, ws.qdd.data());
    detail::add_acceleration_pass(model, ws, ws.qdd.data());
  } else {
    ws.qdd = input;
  }
  // step 2: one backward pass gives c' (ws.tau), M and both derivatives of c'
  detail::backward_pass<S, Level::kDerivatives>(model, ws, &ws.tau, /*with_mass=*/true, /*with_dq=*/true);
  bool factored = false;
  if (!supplied_minv) {
    if (Status s = factorize_mass_matrix(model, ws); !s) return s;
    inverse_from_factors(model, ws);
    factored = true;
  }
  const MatrixX<S>& Minv = supplied_minv ? *supplied_minv : ws.Minv;
  // step 3: dqdd/du = -M^-1 dc'/du
  multiply_by_minus_minv(model, Minv, ws.dtau_dq, ws.dqdd_dq);
  multiply_by_minus_minv(model, Minv, ws.dtau_dqd, ws.dqdd_dqd);
  if (factored) return guard.finish(ws.qdd, ws.Minv, ws.dqdd_dq, ws.dqdd_dqd);
  return guard.finish(ws.qdd, ws.dqdd_dq, ws.dqdd_dqd);
}

#define RBDGRAD_INSTANTIATE(S)                                                                           \
  template Status fd_derivatives<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&, \
                                    const ConstVectorRef<S>&, const ConstVectorRef<S>&, \
                                    InputKind, std::type_identity_t<const S*>, \
                                    std::type_identity_t<const MatrixX<S>*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
