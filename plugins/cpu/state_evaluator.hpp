// Evaluates the requested outputs of one batch state in one scalar type through the core's
// evaluate_outputs (which runs only the algorithms those outputs need, each specialized for the
// batch's execution plan) and writes them into the batch. External forces and the caller's M^-1
// are passed on.
#pragma once

#include <cstddef>

#include "common/batch_view.hpp"
#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::plugin {

template <class S>
class StateEvaluator {
 public:
  /// Sizes every buffer for `model` (nothing allocates afterwards).
  explicit StateEvaluator(const ModelTpl<S>& model);

  /// The execution plan of a validated batch: the stages its outputs, fext and M^-1 need
  /// (plan_request), derived once per batch.
  static ExecutionPlan plan(const ModelTpl<S>& model, const rbdgrad_batch& batch);

  /// Computes the outputs of state k of a validated batch under its plan and writes them into the batch.
  /// \return ok, or the core error for this state (its outputs are then partly written).
  Status evaluate(const ModelTpl<S>& model, const BatchView<S>& batch, std::size_t k, const ExecutionPlan& plan);

 private:
  WorkspaceTpl<S> ws_;
  StateBuffers<S> buffers_;
};

}  // namespace rbdgrad::plugin
