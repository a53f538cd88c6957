#include "evaluator.hpp"

#include <cmath>
#include <cstdio>

#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad::cli {

namespace {

template <class S>
void copy_out(const VectorX<S>& v, std::vector<double>& out) {
  for (Eigen::Index i = 0; i < v.size(); ++i) out[static_cast<std::size_t>(i)] = static_cast<double>(v(i));
}

// Eigen stores column-major; files are row-major: element (i, j) at i * cols + j.
template <class S>
void copy_out(const MatrixX<S>& m, std::vector<double>& out) {
  const Eigen::Index cols = m.cols();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < cols; ++j) out[static_cast<std::size_t>(i * cols + j)] = static_cast<double>(m(i, j));
}

bool is_matrix(int k) { return k != kQdd && k != kTauId; }

std::string format_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::optional<OutputSet> parse_outputs(std::string_view list, std::string& error) {
  OutputSet set{};
  bool any = false;
  while (!list.empty()) {
    const std::size_t cut = list.find(',');
    const std::string_view name = list.substr(0, cut);
    list = cut == std::string_view::npos ? std::string_view() : list.substr(cut + 1);
    if (name.empty()) continue;
    int k = 0;
    while (k < kNumOutputs && kOutputNames[static_cast<std::size_t>(k)] != name) ++k;
    if (k == kNumOutputs) {
      error = "unknown output '" + std::string(name) + "' (known: qdd, M, Minv, dqdd_dq, dqdd_dqd, tau_id, dtau_dq, dtau_dqd)";
      return std::nullopt;
    }
    set[static_cast<std::size_t>(k)] = any = true;
  }
  if (!any) {
    error = "--outputs names no output";
    return std::nullopt;
  }
  return set;
}

template <class S>
Evaluator<S>::Evaluator(const Model& model, const OutputSet& outputs)
    : model_(model.cast<S>()), ws_(model_), outputs_(outputs) {
  const int n = model_.nv;
  q_.resize(n);
  qd_.resize(n);
  input_.resize(n);
  // buffers sized once: the loop over states does not allocate for results
  for (int k = 0; k < kNumOutputs; ++k) {
    if (!outputs_[static_cast<std::size_t>(k)]) continue;
    std::vector<double>& r = results_[static_cast<std::size_t>(k)];
    r.resize(static_cast<std::size_t>(is_matrix(k) ? n * n : n));
    arrays_.push_back({kOutputNames[static_cast<std::size_t>(k)], r.data(), r.size()});
  }
}

// float64 -> S one element at a time, so that a value outside the range of S is named: f32 overflows
// to Inf, Q16.16 saturates at +-32768 (FixedOverflowScope sees it).
template <class S>
Status Evaluator<S>::convert_input(const io::StateRecord& s, const char* field, VectorX<S>& out) const {
  const std::vector<double>& x = *s.find(field);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const double v = x[static_cast<std::size_t>(i)];
    FixedOverflowScope scope;
    out(i) = static_cast<S>(v);
    bool fits = true;
    if constexpr (is_fixed_point_v<S>) fits = !scope.overflowed();
    else fits = std::isfinite(static_cast<double>(out(i)));
    if (!fits)
      return out_of_range("field '" + std::string(field) + "' element " +
                          std::to_string(i) + " (" + format_number(v) + ") is outside the range of " +
                          scalar_name<S>());
  }
  return Status::ok();
}

template <class S>
Status Evaluator<S>::evaluate(const io::StateRecord& s) {
  const bool tau_input = s.has("tau");
  if (Status st = convert_input(s, "q", q_); !st) return st;
  if (Status st = convert_input(s, "qd", qd_); !st) return st;
  if (Status st = convert_input(s, tau_input ? "tau" : "qdd", input_); !st) return st;
  return run(tau_input);
}

template <class S>
Status Evaluator<S>::run(bool tau_input) {
  // the CLI's output order -> the core's output flags
  constexpr std::uint32_t kFlags[kNumOutputs] = {kOutputQdd,     kOutputM,   kOutputMinv,   kOutputDqddDq,
                                                 kOutputDqddDqd, kOutputTau, kOutputDtauDq, kOutputDtauDqd};
  std::uint32_t flags = 0;
  for (int k = 0; k < kNumOutputs; ++k)
    if (outputs_[static_cast<std::size_t>(k)]) flags |= kFlags[k];
  if (Status st = evaluate_outputs(model_, ws_, q_, qd_, input_, tau_input ? InputKind::kTau : InputKind::kQdd, flags);
      !st)
    return st;
  auto out = [&](Output k) -> std::vector<double>& { return results_[static_cast<std::size_t>(k)]; };
  auto want = [&](Output k) { return outputs_[static_cast<std::size_t>(k)]; };
  if (want(kQdd)) copy_out(ws_.qdd, out(kQdd));
  if (want(kM)) copy_out(ws_.M, out(kM));
  if (want(kMinv)) copy_out(ws_.Minv, out(kMinv));
  if (want(kDqddDq)) copy_out(ws_.dqdd_dq, out(kDqddDq));
  if (want(kDqddDqd)) copy_out(ws_.dqdd_dqd, out(kDqddDqd));
  if (want(kTauId)) copy_out(ws_.tau, out(kTauId));
  if (want(kDtauDq)) copy_out(ws_.dtau_dq, out(kDtauDq));
  if (want(kDtauDqd)) copy_out(ws_.dtau_dqd, out(kDtauDqd));
  return Status::ok();
}

#define RBDGRAD_INSTANTIATE(S) template class Evaluator<S>;
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad::cli
