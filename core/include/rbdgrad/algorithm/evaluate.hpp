// One state, any subset of outputs: runs only the algorithms the requested outputs need. Shared
// by every front end (the CLI evaluator, the CPU plugin) so that they choose alike.
#pragma once

#include <cstdint>

#include "rbdgrad/algorithm/fd_derivatives.hpp"

namespace rbdgrad {

// Output flags; the values are those of the plugin ABI (rbdgrad_output).
enum OutputFlag : std::uint32_t {
  kOutputQdd = 1,
  kOutputMinv = 2,
  kOutputDqddDq = 4,
  kOutputDqddDqd = 8,
  kOutputTau = 16,
  kOutputDtauDq = 32,
  kOutputDtauDqd = 64,
  kOutputM = 128,
};
inline constexpr std::uint32_t kAllOutputs = 255;

/// Computes the requested outputs of one state.
/// - M^-1 or d qdd/d(q, qd): fd_derivatives (gives qdd, leaves M);
/// - else qdd from tau when qdd, tau or d tau/d(q, qd) is requested: forward_dynamics (no M);
/// - tau and its derivatives at that qdd (or the input qdd): rnea_derivatives (leaves M), or rnea;
/// - M from one of the above when it ran, else crba.
/// With a caller's M^-1 the derivatives use it, and a requested Minv output is M^-1(q) computed
/// here (the supplied matrix may be cached from another q).
/// \param[in] q, qd, input (dim model.nv), kind: input is tau or qdd; fext, supplied_minv as in
///            fd_derivatives; outputs: OutputFlag bits, at least one.
/// \param[out] ws.qdd, ws.Minv, ws.dqdd_dq, ws.dqdd_dqd, ws.tau, ws.dtau_dq, ws.dtau_dqd, ws.M:
///             those requested hold the state's values (ws.qdd also when tau outputs need it).
template <class S>
Status evaluate_outputs(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                        std::uint32_t outputs, std::type_identity_t<const S*> fext = nullptr,
                        std::type_identity_t<const MatrixX<S>*> supplied_minv = nullptr);

/// The same under an execution plan (a scene's, or plan_request's for this request, which the
/// overload above uses): every algorithm run takes the plan's gravity and external forces, the
/// derivatives only the columns the outputs ask for, and a supplied M^-1 only when the plan says so.
/// Errors: invalid_argument when the plan does not fit the model or the data (check_plan) or
/// excludes a requested d qdd column.
template <class S>
Status evaluate_outputs(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
                        const ConstVectorRef<S>& qd, const ConstVectorRef<S>& input, InputKind kind,
                        std::uint32_t outputs, const ExecutionPlan& plan, std::type_identity_t<const S*> fext,
                        std::type_identity_t<const MatrixX<S>*> supplied_minv);

}  // namespace rbdgrad
