// Evaluates the requested dynamics outputs for one state at a time, in one scalar type, running
// only the algorithms those outputs need. Results come back as float64 arrays, matrices row-major.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rbdgrad/io/state_file.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/spatial.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::cli {

// The outputs, in file order; the names are the reference files' field names.
enum Output : int { kQdd, kM, kMinv, kDqddDq, kDqddDqd, kTauId, kDtauDq, kDtauDqd, kNumOutputs };
inline constexpr std::array<std::string_view, kNumOutputs> kOutputNames = {
    "qdd", "M", "Minv", "dqdd_dq", "dqdd_dqd", "tau_id", "dtau_dq", "dtau_dqd"};

using OutputSet = std::array<bool, kNumOutputs>;

// "qdd,M" -> {qdd, M}; nullopt and `error` filled for an unknown or empty list.
std::optional<OutputSet> parse_outputs(std::string_view list, std::string& error);

template <class S>
class Evaluator {
 public:
  /// \param[in] model the float64 model, cast to S once here.
  /// \param[in] outputs what evaluate() computes; the rest is skipped.
  Evaluator(const Model& model, const OutputSet& outputs);

  /// Computes the outputs for state `s`, whose inputs were checked (io::check_dynamics_input):
  /// q, qd, and tau (then qdd = FD(q, qd, tau)) or else qdd. tau_id and its derivatives are
  /// evaluated at that qdd.
  /// \return ok, or the error (the caller names the state): an input outside the range of S
  ///         (out_of_range), singular M (failed_precondition), fixed-point overflow or a non-finite
  ///         result (out_of_range).
  Status evaluate(const io::StateRecord& s);

  // Valid after a successful evaluate(): one entry per selected output, in kOutputNames order
  // (vectors nv, matrices nv x nv row-major). Points into this object.
  const std::vector<io::OutputArray>& arrays() const { return arrays_; }

 private:
  Status convert_input(const io::StateRecord& s, const char* field, VectorX<S>& out) const;
  // the algorithms the selected outputs need, on q_, qd_ and input_ (tau or qdd)
  Status run(bool tau_input);

  ModelTpl<S> model_;
  WorkspaceTpl<S> ws_;
  OutputSet outputs_;
  VectorX<S> q_, qd_, input_;  // (nv) inputs in S
  std::array<std::vector<double>, kNumOutputs> results_;  // float64 copies of the outputs
  std::vector<io::OutputArray> arrays_;
};

}  // namespace rbdgrad::cli
