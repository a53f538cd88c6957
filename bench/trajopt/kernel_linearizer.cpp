// The in-process kernel's linearization: see kernel_linearizer.hpp.
#include "kernel_linearizer.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

namespace rbdgrad::trajopt {

namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// state k's nv x nv matrix of a state-major, row-major array
Eigen::Map<const RowMajor> matrix(const std::vector<double>& v, std::size_t k, int nv) {
  return Eigen::Map<const RowMajor>(v.data() + k * static_cast<std::size_t>(nv * nv), nv, nv);
}

}  // namespace

KernelLinearizer::KernelLinearizer(bench::FixedFormat format, ArmPlant& reference)
    : format_(std::move(format)), reference_(reference) {
  stats_.backend_mode = "host";
}

std::string KernelLinearizer::operator()(const Trajectory& t, Linearization& out) {
  const std::size_t horizon = t.u.size();
  const int nv = reference_.nv();
  const std::size_t n = static_cast<std::size_t>(nv);
  states_.nv = nv;
  states_.n = horizon;
  states_.q.resize(horizon * n);
  states_.qd.resize(horizon * n);
  states_.tau.resize(horizon * n);
  for (std::size_t k = 0; k < horizon; ++k) {
    Eigen::Map<Eigen::VectorXd>(states_.q.data() + k * n, nv) = t.x[k].head(nv);
    Eigen::Map<Eigen::VectorXd>(states_.qd.data() + k * n, nv) = t.x[k].tail(nv);
    Eigen::Map<Eigen::VectorXd>(states_.tau.data() + k * n, nv) = t.u[k];
  }
  // timed as the daemon's call is: the whole batch, the host's M⁻¹ and the roundings included
  const auto start = std::chrono::steady_clock::now();
  const Status status = bench::run_fixed_format(format_, reference_.model(), states_, result_);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats_.gradient_s += elapsed;
  stats_.server_compute_s += elapsed;
  if (!status) return status.to_string();
  const int iteration = ++stats_.calls;
  stats_.states += horizon;

  const auto flagged = static_cast<std::size_t>(
      std::count_if(result_.state_status.begin(), result_.state_status.end(), [](std::int32_t s) { return s != 0; }));
  if (flagged > 0) {
    stats_.overflowed_states = flagged;
    const auto first = static_cast<std::size_t>(
        std::find_if(result_.state_status.begin(), result_.state_status.end(), [](std::int32_t s) { return s != 0; }) -
        result_.state_status.begin());
    return "state " + std::to_string(first) + " of iteration " + std::to_string(iteration) + " overflowed in " +
           format_.name + " (" + std::to_string(flagged) + " of " + std::to_string(horizon) + " states flagged)";
  }

  out.A.resize(horizon);
  out.B.resize(horizon);
  for (std::size_t k = 0; k < horizon; ++k) {
    euler_jacobians(reference_.dt(), matrix(result_.dqdd_dq, k, nv), matrix(result_.dqdd_dqd, k, nv),
                    matrix(result_.minv, k, nv), out.A[k], out.B[k]);
    if (!out.A[k].allFinite() || !out.B[k].allFinite())
      return "state " + std::to_string(k) + ": the derivatives are not finite";
  }
  const auto check_start = std::chrono::steady_clock::now();
  for (std::size_t k = 0; k < horizon; ++k) {
    if (!reference_.reference_derivatives(t.x[k].head(nv), t.x[k].tail(nv), t.u[k]))
      return "state " + std::to_string(k) + ": the reference derivatives failed";
    const Workspace& ws = reference_.workspace();
    stats_.max_grad_error =
        std::max(stats_.max_grad_error, jacobian_error(matrix(result_.dqdd_dq, k, nv), matrix(result_.dqdd_dqd, k, nv),
                                                       ws.dqdd_dq, ws.dqdd_dqd));
    stats_.max_minv_error = std::max(stats_.max_minv_error, relative_error(matrix(result_.minv, k, nv), ws.Minv));
  }
  stats_.check_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - check_start).count();
  return "";
}

}  // namespace rbdgrad::trajopt
