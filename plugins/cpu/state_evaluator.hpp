// Evaluates the requested outputs of one batch state in one scalar type, running only the core
// algorithms those outputs need. The selection follows tools/cli/evaluator.cpp:
// - M^-1 or d qdd/d(q, qd): fd_derivatives (it also gives qdd and leaves M(q) in the workspace);
// - else qdd from tau when qdd, tau or d tau/d(q, qd) is asked for: forward_dynamics (ABA, no M);
// - tau and its derivatives at that qdd (or at the input qdd): rnea_derivatives (leaves M(q)), or
//   rnea for tau alone;
// - M: from the algorithms above when one ran, else crba.
// Additions for the plugin ABI: external forces go to every algorithm that takes them, and the
// caller's M^-1 goes to fd_derivatives. With a caller's M^-1 the MINV output is still M^-1(q),
// computed by minverse: the supplied matrix may be a cached one from another q.
#pragma once

#include <cstddef>

#include "common/batch_view.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::plugin {

template <class S>
class StateEvaluator {
 public:
  /// Sizes every buffer for `model` (nothing allocates afterwards).
  explicit StateEvaluator(const ModelTpl<S>& model);

  /// Computes the outputs of state k of a validated batch and writes them into the batch.
  /// \return ok, or the core error for this state (its outputs are then partly written).
  Status evaluate(const ModelTpl<S>& model, const BatchView<S>& batch, std::size_t k);

 private:
  WorkspaceTpl<S> ws_;
  StateBuffers<S> buffers_;
  VectorX<S> qdd_;  // (nv) the qdd the inverse dynamics use (computed, or the input)
};

}  // namespace rbdgrad::plugin
