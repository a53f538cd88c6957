#include "rbdgrad/algorithm/fd_derivatives.hpp"

#include <type_traits>

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "articulated_body_pass.hpp"

namespace rbdgrad {

template <class S>
Status fd_derivatives(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                      const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input,
                      InputKind kind, std::type_identity_t<const S*> fext,
                      std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  using detail::Level;
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
  // step 1 (Algorithm 3): RNEA quantities v', a', f'; step 2: the derivatives of c' = RNEA(q, qd, qdd)
  if (kind == InputKind::kQdd) {
    detail::forward_pass<S, Level::kDerivatives>(model, ws, q.data(), qd.data(), input.data(), fext);
    detail::backward_pass<S, Level::kDerivatives>(model, ws, &ws.tau, /*with_mass=*/true, /*with_dq=*/true);
    if (Status s = inverse(); !s) return s;
    ws.qdd = input;
  } else if constexpr (std::is_same_v<S, double>) {
    // tau input, f64: a first pass with qdd = 0 gives c, M and d tau/d qd (which does not depend
    // on qdd); qdd = M^-1 (tau - c) through the factors of M needed anyway (1e-13 accurate in f64,
    // cheaper than the articulated-body pass); then the qdd part of the motion and d tau/d q.
    detail::forward_pass<S, Level::kDerivatives>(model, ws, q.data(), qd.data(), nullptr, fext);
    detail::backward_pass<S, Level::kDerivatives>(model, ws, &ws.tau, /*with_mass=*/true, /*with_dq=*/false);
    if (Status s = inverse(); !s) return s;
    ws.qdd = input - ws.tau;
    if (factored) solve_with_factors(model, ws, ws.qdd);
    else ws.qdd = (*supplied_minv * ws.qdd).eval();
    detail::add_acceleration_pass(model, ws, ws.qdd.data(), /*into_body_force=*/false);
    detail::derivative_dq_pass(model, ws);
    ws.tau = input;
  } else {
    // tau input, f32 and fixed point: M^-1 (tau - c) loses three digits in float, the
    // articulated-body pass about the joint points does not; it runs on the same velocities.
    detail::forward_pass<S, Level::kDerivatives, /*kForAba=*/true>(model, ws, q.data(), qd.data(), nullptr, fext);
    detail::articulated_body_pass(model, ws, qd.data(), input.data(), fext, ws.qdd.data());
    detail::add_acceleration_pass(model, ws, ws.qdd.data(), /*into_body_force=*/true);
    detail::backward_pass<S, Level::kDerivatives>(model, ws, &ws.tau, /*with_mass=*/true, /*with_dq=*/true);
    if (Status s = inverse(); !s) return s;
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
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
