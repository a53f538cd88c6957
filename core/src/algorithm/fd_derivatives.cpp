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
  // step 1 (Algorithm 3): RNEA quantities v', a', f'. With tau as input, qdd is not known yet: run
  // with qdd = 0, which gives c, M and d tau/d qd (independent of qdd), then add the qdd part.
  detail::forward_pass<S, Level::kDerivatives>(model, ws, q.data(), qd.data(), tau_input ? nullptr : input.data(),
                                               fext);
  detail::backward_pass<S, Level::kDerivatives>(model, ws, tau_input ? &ws.bias : &ws.tau, /*with_mass=*/true,
                                                /*with_dq=*/!tau_input);
  bool factored = false;
  if (!supplied_minv) {
    if (Status s = factorize_mass_matrix(model, ws); !s) return s;
    inverse_from_factors(model, ws);
    factored = true;
  }
  const MatrixX<S>& Minv = supplied_minv ? *supplied_minv : ws.Minv;
  if (tau_input) {
    // qdd by the articulated-body recursion on the velocities already computed (accurate in float)
    detail::articulated_body_pass(model, ws, qd.data(), input.data(), fext, ws.qdd.data());
    ws.tau = input;
    // step 2: the derivative terms that depend on qdd
    detail::add_acceleration_pass(model, ws, ws.qdd.data());
    detail::derivative_dq_pass(model, ws);
  } else {
    ws.qdd = input;
  }
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
