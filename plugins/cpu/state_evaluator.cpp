#include "state_evaluator.hpp"

#include "rbdgrad/algorithm/crba.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/algorithm/rnea.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad::plugin {

template <class S>
StateEvaluator<S>::StateEvaluator(const ModelTpl<S>& model)
    : ws_(model), buffers_(model.nv), qdd_(VectorX<S>::Zero(model.nv)) {}

template <class S>
Status StateEvaluator<S>::evaluate(const ModelTpl<S>& model, const BatchView<S>& batch, std::size_t k) {
  const std::uint32_t outputs = batch.batch().outputs;
  auto want = [&](std::uint32_t flags) { return (outputs & flags) != 0; };
  const bool tau_input = batch.batch().input_kind == RBDGRAD_INPUT_TAU;
  const bool want_fd = want(RBDGRAD_OUTPUT_MINV | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD);
  const bool want_id_derivatives = want(RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_DTAU_DQD);
  const bool want_id = want(RBDGRAD_OUTPUT_TAU) || want_id_derivatives;
  const StateInputs<S> in = batch.inputs(k, buffers_);
  bool have_M = false;  // fd_derivatives and rnea_derivatives leave M(q) in ws_.M

  // forward dynamics: the derivatives (and M^-1) when asked for, else only the qdd that is needed
  if (want_fd) {
    const InputKind kind = tau_input ? InputKind::kTau : InputKind::kQdd;
    if (Status s = fd_derivatives(model, ws_, in.q, in.qd, in.u, kind, in.fext, in.minv); !s) return s;
    have_M = true;
    if (want(RBDGRAD_OUTPUT_DQDD_DQ)) batch.write(RBDGRAD_OUTPUT_DQDD_DQ, k, ws_.dqdd_dq);
    if (want(RBDGRAD_OUTPUT_DQDD_DQD)) batch.write(RBDGRAD_OUTPUT_DQDD_DQD, k, ws_.dqdd_dqd);
    qdd_ = ws_.qdd;
    if (want(RBDGRAD_OUTPUT_MINV)) {
      // fd_derivatives skipped M^-1 when the caller supplied one: compute the true M^-1(q)
      if (in.minv != nullptr) {
        if (Status s = minverse(model, ws_, in.q); !s) return s;
      }
      batch.write(RBDGRAD_OUTPUT_MINV, k, ws_.Minv);
    }
  } else if (tau_input && (want(RBDGRAD_OUTPUT_QDD) || want_id)) {
    // articulated-body algorithm: qdd only, M is not formed
    if (Status s = forward_dynamics(model, ws_, in.q, in.qd, in.u, in.fext); !s) return s;
    qdd_ = ws_.qdd;
  } else if (want(RBDGRAD_OUTPUT_QDD) || want_id) {
    qdd_ = in.u;  // qdd input
  }
  if (want(RBDGRAD_OUTPUT_QDD)) batch.write(RBDGRAD_OUTPUT_QDD, k, qdd_);

  // inverse dynamics at that qdd
  if (want_id_derivatives) {
    if (Status s = rnea_derivatives(model, ws_, in.q, in.qd, qdd_, in.fext); !s) return s;
    have_M = true;
    if (want(RBDGRAD_OUTPUT_DTAU_DQ)) batch.write(RBDGRAD_OUTPUT_DTAU_DQ, k, ws_.dtau_dq);
    if (want(RBDGRAD_OUTPUT_DTAU_DQD)) batch.write(RBDGRAD_OUTPUT_DTAU_DQD, k, ws_.dtau_dqd);
  } else if (want_id) {
    if (Status s = rnea(model, ws_, in.q, in.qd, qdd_, in.fext); !s) return s;
  }
  if (want(RBDGRAD_OUTPUT_TAU)) batch.write(RBDGRAD_OUTPUT_TAU, k, ws_.tau);

  if (want(RBDGRAD_OUTPUT_M)) {
    if (!have_M) {
      if (Status s = crba(model, ws_, in.q); !s) return s;
    }
    batch.write(RBDGRAD_OUTPUT_M, k, ws_.M);
  }
  return Status::ok();
}

#define RBDGRAD_INSTANTIATE(S) template class StateEvaluator<S>;
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad::plugin
