#include "error_summary.hpp"

#include <algorithm>
#include <cmath>

namespace rbdgrad::bench {
namespace {

// ||a - b||_F / ||b||_F over one matrix (||a - b|| when b is zero)
double relative_error(const double* a, const double* b, std::size_t count) {
  double diff = 0, norm = 0;
  for (std::size_t e = 0; e < count; ++e) {
    diff += (a[e] - b[e]) * (a[e] - b[e]);
    norm += b[e] * b[e];
  }
  return norm > 0 ? std::sqrt(diff / norm) : std::sqrt(diff);
}

ErrorSummary summarize(std::vector<double> errors) {
  ErrorSummary s;
  if (errors.empty()) return s;
  std::sort(errors.begin(), errors.end());
  s.median = errors[errors.size() / 2];
  s.worst = errors.back();
  return s;
}

}  // namespace

GradientErrors compare_gradients(const Gradients& got, const std::vector<double>& want_dq,
                                 const std::vector<double>& want_dqd, int nv) {
  GradientErrors out;
  const std::size_t per_state = static_cast<std::size_t>(nv) * static_cast<std::size_t>(nv);
  const std::size_t n = got.state_status.size();
  std::vector<double> dq, dqd;
  for (std::size_t k = 0; k < n; ++k) {
    if (got.state_status[k] != 0) {
      ++out.flagged;
      continue;
    }
    const double* a = got.dqdd_dq.data() + k * per_state;
    const double* b = got.dqdd_dqd.data() + k * per_state;
    bool finite = true;
    for (std::size_t e = 0; e < per_state && finite; ++e) finite = std::isfinite(a[e]) && std::isfinite(b[e]);
    if (!finite) {
      ++out.unflagged_nonfinite;
      continue;
    }
    dq.push_back(relative_error(a, want_dq.data() + k * per_state, per_state));
    dqd.push_back(relative_error(b, want_dqd.data() + k * per_state, per_state));
    ++out.states;
  }
  out.dqdd_dq = summarize(std::move(dq));
  out.dqdd_dqd = summarize(std::move(dqd));
  return out;
}

}  // namespace rbdgrad::bench
