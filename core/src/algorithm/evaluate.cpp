#include "rbdgrad/algorithm/evaluate.hpp"

#include "rbdgrad/algorithm/crba.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/algorithm/rnea.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {

template <class S>
Status evaluate_outputs(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                        std::uint32_t outputs, std::type_identity_t<const S*> fext,
                        std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  const ExecutionPlan plan = plan_request(model, outputs, fext, supplied_minv);
  return evaluate_outputs(model, ws, q, qd, input, kind, outputs, plan, fext, supplied_minv);
}

template <class S>
Status evaluate_outputs(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                        std::uint32_t outputs, const ExecutionPlan& plan, std::type_identity_t<const S*> fext,
                        std::type_identity_t<const MatrixX<S>*> supplied_minv) {
  auto want = [&](std::uint32_t flags) { return (outputs & flags) != 0; };
  if (Status s = check_plan(model.nv, plan, fext != nullptr, supplied_minv != nullptr); !s) return s;
  if ((want(kOutputDqddDq) && !plan.dqdd_dq) || (want(kOutputDqddDqd) && !plan.dqdd_dqd))
    return invalid_argument("the execution plan excludes a requested d qdd column");
  const bool tau_input = kind == InputKind::kTau;
  const bool want_fd = want(kOutputMinv | kOutputDqddDq | kOutputDqddDqd);
  const bool want_id_derivatives = want(kOutputDtauDq | kOutputDtauDqd);
  const bool want_id = want(kOutputTau) || want_id_derivatives;
  const bool forces = plan.external_forces != ExternalForces::kNone;
  bool have_M = false;  // fd_derivatives and rnea_derivatives leave M(q) in ws.M

  // forward dynamics: the derivative columns asked for, else only the qdd that is needed
  if (want_fd) {
    ExecutionPlan fd_plan = plan;
    fd_plan.dqdd_dq = want(kOutputDqddDq);
    fd_plan.dqdd_dqd = want(kOutputDqddDqd);
    if (Status s = fd_derivatives(model, ws, q, qd, input, kind, fd_plan, fext, supplied_minv); !s) return s;
    have_M = true;
    if (want(kOutputMinv) && plan.minv_supplied) {
      if (Status s = minverse(model, ws, q); !s) return s;
    }
  } else if (tau_input && (want(kOutputQdd) || want_id)) {
    if (Status s = forward_dynamics(model, ws, q, qd, input, plan, fext); !s) return s;
  } else if (!tau_input && (want(kOutputQdd) || want_id)) {
    // not when only M is asked for: the input may then be absent (the plugin ABI allows NULL)
    ws.qdd = input;
  }

  // inverse dynamics at that qdd (rnea and rnea_derivatives do not write ws.qdd)
  if (want_id_derivatives) {
    const GradientStages stages{want(kOutputDtauDq), want(kOutputDtauDqd), forces};
    const Status s = dispatch_stages(stages, [&]<GradientStages kStages>() {
      return rnea_derivatives_specialized<kStages, S>(model, ws, q, qd, ws.qdd, plan.gravity, fext,
                                                      forced_bodies(plan));
    });
    if (!s) return s;
    have_M = true;
  } else if (want_id) {
    if (Status s = rnea(model, ws, q, qd, ws.qdd, plan, fext); !s) return s;
  }

  if (want(kOutputM) && !have_M) return crba(model, ws, q);
  return Status::ok();
}

#define RBDGRAD_INSTANTIATE(S)                                                                            \
  template Status evaluate_outputs<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&,      \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, InputKind,       \
                                      std::uint32_t, std::type_identity_t<const S*>,                       \
                                      std::type_identity_t<const MatrixX<S>*>);                            \
  template Status evaluate_outputs<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&,      \
                                      const ConstVectorRef<S>&, const ConstVectorRef<S>&, InputKind,       \
                                      std::uint32_t, const ExecutionPlan&, std::type_identity_t<const S*>, \
                                      std::type_identity_t<const MatrixX<S>*>);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
