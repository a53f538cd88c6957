// One state through fd_derivatives in one precision, measured against the same computation in
// long double (64-bit mantissa, 2^11 times finer than f64): the relative Frobenius error of
// dqdd_dq and dqdd_dqd, and whether a NaN, Inf or saturated value was flagged or passed on silently.
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <string>

#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "stability_cases.hpp"

namespace rbdgrad::stability {

using LongDouble = long double;

struct Reference {
  bool ok = false;  // false: the reference itself failed (the state is then not measured)
  Eigen::MatrixXd dq, dqd;
  double cond = 0;  // condition number of M(q), from its eigenvalues in long double
};

// An output whose reference norm is below this is zero in exact arithmetic (dqdd/dqd of a body
// hanging alone from the world, dqdd/dq of one joint without gravity): the reference then holds
// only rounding noise, so the absolute error is measured instead of the relative one (as
// testing::relative_error does for an exact zero). On the tests' grid the zero outputs measure at
// most 4e-19 and all others at least 2e-2.
inline constexpr double kZeroReference = 1e-9;

inline double output_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref) {
  return ref.norm() > kZeroReference ? testing::relative_error(x, ref) : (x - ref).norm();
}

struct Outcome {
  bool flagged = false;      // non-ok Status or fixed-point overflow (inputs included): result refused
  bool bad_output = false;   // a NaN or Inf, or a fixed-point element at the end of its range
  // relative errors (absolute against a zero reference, see kZeroReference); NaN when flagged
  double err_dq = std::numeric_limits<double>::quiet_NaN();
  double err_dqd = std::numeric_limits<double>::quiet_NaN();
  std::string message;       // the Status when flagged

  // the failure the stress tests exist to catch: a broken result handed on as if valid
  bool silent_failure() const { return bad_output && !flagged; }
  double error() const { return std::fmax(err_dq, err_dqd); }
};

template <class S>
bool outputs_bad(const MatrixX<S>& x) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const S v = x.data()[k];
    if constexpr (is_fixed_point_v<S>) {
      if (v == std::numeric_limits<S>::max() || v == std::numeric_limits<S>::lowest()) return true;
    } else {
      using std::isfinite;
      if (!isfinite(v)) return true;
    }
  }
  return false;
}

// fd_derivatives for one model in scalar S, its workspace built once.
template <class S>
class PrecisionRun {
 public:
  explicit PrecisionRun(const Model& model) : model_(model.cast<S>()), ws_(model_) {}

  Outcome run(const StateInput& s, const Reference& ref) {
    Outcome out;
    const FixedOverflowScope overflow;  // a state out of the fixed-point range overflows on conversion
    const VectorX<S> q = s.q.cast<S>(), qd = s.qd.cast<S>(), tau = s.tau.cast<S>();
    const Status st = fd_derivatives(model_, ws_, q, qd, tau, InputKind::kTau);
    out.flagged = !st.is_ok() || overflow.overflowed();
    if (!st.is_ok()) out.message = st.to_string();
    else if (out.flagged) out.message = "fixed-point overflow converting the inputs";
    out.bad_output = outputs_bad<S>(ws_.qdd) || outputs_bad<S>(ws_.dqdd_dq) || outputs_bad<S>(ws_.dqdd_dqd);
    if (!out.flagged && ref.ok) {
      out.err_dq = output_error(to_double(ws_.dqdd_dq), ref.dq);
      out.err_dqd = output_error(to_double(ws_.dqdd_dqd), ref.dqd);
    }
    return out;
  }

  const ModelTpl<S>& model() const { return model_; }
  const WorkspaceTpl<S>& workspace() const { return ws_; }

 private:
  static Eigen::MatrixXd to_double(const MatrixX<S>& x) {
    Eigen::MatrixXd d(x.rows(), x.cols());
    for (Eigen::Index k = 0; k < x.size(); ++k) d.data()[k] = static_cast<double>(x.data()[k]);
    return d;
  }

  ModelTpl<S> model_;
  WorkspaceTpl<S> ws_;
};

// The long double computation that the others are measured against, and cond(M).
class ReferenceRun {
 public:
  explicit ReferenceRun(const Model& model) : run_(model) {}

  Reference run(const StateInput& s) {
    Reference ref;
    const Outcome o = run_.run(s, ref);
    if (o.flagged || o.bad_output) return ref;
    const WorkspaceTpl<LongDouble>& ws = run_.workspace();
    ref.dq = ws.dqdd_dq.cast<double>();
    ref.dqd = ws.dqdd_dqd.cast<double>();
    if (!ref.dq.allFinite() || !ref.dqd.allFinite()) return ref;  // beyond the range of double
    const Eigen::SelfAdjointEigenSolver<MatrixX<LongDouble>> eig(ws.M, Eigen::EigenvaluesOnly);
    const VectorX<LongDouble>& ev = eig.eigenvalues();  // ascending
    ref.cond = ev(0) > 0 ? static_cast<double>(ev(ev.size() - 1) / ev(0)) : std::numeric_limits<double>::infinity();
    ref.ok = true;
    return ref;
  }

 private:
  PrecisionRun<LongDouble> run_;
};

}  // namespace rbdgrad::stability
