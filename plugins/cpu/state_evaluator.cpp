#include "state_evaluator.hpp"

#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad::plugin {

template <class S>
StateEvaluator<S>::StateEvaluator(const ModelTpl<S>& model)
    : ws_(model), buffers_(model.nv) {}

template <class S>
ExecutionPlan StateEvaluator<S>::plan(const ModelTpl<S>& model, const rbdgrad_batch& batch) {
  // the ABI's output flags are the core's OutputFlag values
  return plan_request(model, batch.outputs, batch.fext, batch.minv);
}

template <class S>
Status StateEvaluator<S>::evaluate(const ModelTpl<S>& model, const BatchView<S>& batch, std::size_t k,
                                   const ExecutionPlan& plan) {
  const std::uint32_t outputs = batch.batch().outputs;
  const StateInputs<S> in = batch.inputs(k, buffers_);
  const InputKind kind = batch.batch().input_kind == RBDGRAD_INPUT_TAU ? InputKind::kTau : InputKind::kQdd;
  if (Status s = evaluate_outputs(model, ws_, in.q, in.qd, in.u, kind, outputs, plan, in.fext, in.minv); !s) return s;
  auto write = [&](rbdgrad_output flag, const auto& value) {
    if (outputs & flag) batch.write(flag, k, value);
  };
  write(RBDGRAD_OUTPUT_QDD, ws_.qdd);
  write(RBDGRAD_OUTPUT_MINV, ws_.Minv);
  write(RBDGRAD_OUTPUT_DQDD_DQ, ws_.dqdd_dq);
  write(RBDGRAD_OUTPUT_DQDD_DQD, ws_.dqdd_dqd);
  write(RBDGRAD_OUTPUT_TAU, ws_.tau);
  write(RBDGRAD_OUTPUT_DTAU_DQ, ws_.dtau_dq);
  write(RBDGRAD_OUTPUT_DTAU_DQD, ws_.dtau_dqd);
  write(RBDGRAD_OUTPUT_M, ws_.M);
  return Status::ok();
}

constexpr bool same(rbdgrad_output abi, OutputFlag core) { return static_cast<std::uint32_t>(abi) == core; }
static_assert(same(RBDGRAD_OUTPUT_QDD, kOutputQdd) && same(RBDGRAD_OUTPUT_MINV, kOutputMinv) &&
                  same(RBDGRAD_OUTPUT_DQDD_DQ, kOutputDqddDq) && same(RBDGRAD_OUTPUT_DQDD_DQD, kOutputDqddDqd) &&
                  same(RBDGRAD_OUTPUT_TAU, kOutputTau) && same(RBDGRAD_OUTPUT_DTAU_DQ, kOutputDtauDq) &&
                  same(RBDGRAD_OUTPUT_DTAU_DQD, kOutputDtauDqd) && same(RBDGRAD_OUTPUT_M, kOutputM),
              "the plugin ABI's output flags must equal the core's");

#define RBDGRAD_INSTANTIATE(S) template class StateEvaluator<S>;
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad::plugin
