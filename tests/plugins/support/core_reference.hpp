// The outputs of one state computed by calling the core library directly, for bitwise comparison
// with a backend. Bitwise equality needs the same algorithms in the same order, so this follows the
// selection of tools/cli/evaluator.cpp (which the CPU plugin documents it follows): fd_derivatives
// for M^-1 and d qdd, forward_dynamics for qdd alone from tau, rnea_derivatives or rnea at that qdd,
// crba for M when nothing else formed it; plus minverse for M^-1 when the caller supplied one.
// The derivatives take only the columns asked for (the request's execution plan), as
// evaluate_outputs does: each column set is its own instantiation, and GCC's fused multiply-adds
// may round one expression differently in two of them (tests/core/plan_variants_test.cpp checks
// they agree within 1e-12 in f64).
#pragma once

#include <cstdint>
#include <map>

#include "rbdgrad/algorithm/crba.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/algorithm/rnea.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/plugin_api.h"

namespace rbdgrad::testing {

template <class S>
struct ReferenceInputs {
  VectorX<S> q, qd, u;   // (nv)
  VectorX<S> fext;       // (6 nv), used when with_fext
  MatrixX<S> minv;       // (nv x nv), used when with_minv
  bool with_fext = false, with_minv = false;
};

/// \param[out] out one entry per requested output flag: vectors as nv x 1, matrices nv x nv.
template <class S>
Status reference_state(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const ReferenceInputs<S>& in, bool tau_input,
                       std::uint32_t outputs, std::map<std::uint32_t, MatrixX<S>>& out) {
  auto want = [&](std::uint32_t f) { return (outputs & f) != 0; };
  const S* fext = in.with_fext ? in.fext.data() : nullptr;
  const MatrixX<S>* minv = in.with_minv ? &in.minv : nullptr;
  const bool id_derivatives = want(RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_DTAU_DQD);
  const bool id = want(RBDGRAD_OUTPUT_TAU) || id_derivatives;
  bool have_M = false;
  VectorX<S> qdd = in.u;
  if (want(RBDGRAD_OUTPUT_MINV | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD)) {
    const ExecutionPlan plan = plan_request(m, outputs, fext, minv);
    if (Status s = fd_derivatives(m, ws, in.q, in.qd, in.u, tau_input ? InputKind::kTau : InputKind::kQdd, plan, fext,
                                  minv);
        !s)
      return s;
    have_M = true;
    out[RBDGRAD_OUTPUT_DQDD_DQ] = ws.dqdd_dq;
    out[RBDGRAD_OUTPUT_DQDD_DQD] = ws.dqdd_dqd;
    qdd = ws.qdd;
    if (want(RBDGRAD_OUTPUT_MINV)) {
      if (minv) {
        if (Status s = minverse(m, ws, in.q); !s) return s;
      }
      out[RBDGRAD_OUTPUT_MINV] = ws.Minv;
    }
  } else if (tau_input && (want(RBDGRAD_OUTPUT_QDD) || id)) {
    if (Status s = forward_dynamics(m, ws, in.q, in.qd, in.u, fext); !s) return s;
    qdd = ws.qdd;
  }
  out[RBDGRAD_OUTPUT_QDD] = qdd;
  if (id_derivatives) {
    const GradientStages columns{want(RBDGRAD_OUTPUT_DTAU_DQ), want(RBDGRAD_OUTPUT_DTAU_DQD), fext != nullptr};
    const Status s = dispatch_stages(columns, [&]<GradientStages kStages>() {
      return rnea_derivatives_specialized<kStages, S>(m, ws, in.q, in.qd, qdd, true, fext, nullptr);
    });
    if (!s) return s;
    have_M = true;
    out[RBDGRAD_OUTPUT_DTAU_DQ] = ws.dtau_dq;
    out[RBDGRAD_OUTPUT_DTAU_DQD] = ws.dtau_dqd;
  } else if (id) {
    if (Status s = rnea(m, ws, in.q, in.qd, qdd, fext); !s) return s;
  }
  out[RBDGRAD_OUTPUT_TAU] = ws.tau;
  if (want(RBDGRAD_OUTPUT_M)) {
    if (!have_M) {
      if (Status s = crba(m, ws, in.q); !s) return s;
    }
    out[RBDGRAD_OUTPUT_M] = ws.M;
  }
  // keep only what was asked for
  for (auto it = out.begin(); it != out.end();) it = want(it->first) ? std::next(it) : out.erase(it);
  return Status::ok();
}

}  // namespace rbdgrad::testing
