// The daemon's linearization: see daemon_linearizer.hpp.
#include "daemon_linearizer.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

namespace rbdgrad::trajopt {

DaemonLinearizer::DaemonLinearizer(const Client& client, std::string model, Backend backend, Precision precision,
                                   ArmPlant& reference)
    : client_(client), model_(std::move(model)), backend_(backend), precision_(precision), reference_(reference) {}

std::string DaemonLinearizer::operator()(const Trajectory& t, Linearization& out) {
  const std::size_t horizon = t.u.size();
  const int nv = reference_.nv();
  const std::size_t n = static_cast<std::size_t>(nv);
  q_.resize(horizon * n);
  qd_.resize(horizon * n);
  tau_.resize(horizon * n);
  for (std::size_t k = 0; k < horizon; ++k) {
    Eigen::Map<Eigen::VectorXd>(q_.data() + k * n, nv) = t.x[k].head(nv);
    Eigen::Map<Eigen::VectorXd>(qd_.data() + k * n, nv) = t.x[k].tail(nv);
    Eigen::Map<Eigen::VectorXd>(tau_.data() + k * n, nv) = t.u[k];
  }
  ComputeRequest req;
  req.model = model_;
  req.num_states = static_cast<std::uint32_t>(horizon);
  req.precision = precision_;
  req.backend = backend_;
  req.input = ComputeInput::kTau;
  req.outputs = Output::kQdd | Output::kMinv | Output::kDqddDq | Output::kDqddDqd;
  req.q = q_;
  req.qd = qd_;
  req.u = tau_;
  req.output_type = ScalarType::kF64;
  req.request_id = "trajopt-" + std::string(backend_name(backend_)) + "-" + precision_name(precision_) + "-" +
                   std::to_string(stats_.calls + 1);
  const auto start = std::chrono::steady_clock::now();
  const RpcStatus status = client_.compute(req, result_);
  stats_.gradient_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!status) return status.to_string();
  ++stats_.calls;
  stats_.states += horizon;
  stats_.server_compute_s += static_cast<double>(result_.timings().compute_us) * 1e-6;
  // a hint pins the backend, an explicit precision is kept: anything else is a server bug
  if (result_.backend() != backend_ || result_.precision() != precision_)
    return std::string("the response came from ") + backend_name(result_.backend()) + " in " +
           precision_name(result_.precision()) + ", not as asked";
  stats_.backend_mode = result_.backend_mode();
  stats_.fallback_states += result_.fallback_states().size();

  out.A.resize(horizon);
  out.B.resize(horizon);
  for (std::uint32_t k = 0; k < horizon; ++k) {
    euler_jacobians(reference_.dt(), result_.dqdd_dq(k), result_.dqdd_dqd(k), result_.minv(k), out.A[k], out.B[k]);
    if (!out.A[k].allFinite() || !out.B[k].allFinite())
      return "state " + std::to_string(k) + ": the derivatives are not finite";
  }
  const auto check_start = std::chrono::steady_clock::now();
  for (std::uint32_t k = 0; k < horizon; ++k) {
    if (!reference_.reference_derivatives(t.x[k].head(nv), t.x[k].tail(nv), t.u[k]))
      return "state " + std::to_string(k) + ": the reference derivatives failed";
    const Workspace& ws = reference_.workspace();
    stats_.max_grad_error = std::max(
        stats_.max_grad_error, jacobian_error(result_.dqdd_dq(k), result_.dqdd_dqd(k), ws.dqdd_dq, ws.dqdd_dqd));
    stats_.max_minv_error = std::max(stats_.max_minv_error, relative_error(result_.minv(k), ws.Minv));
  }
  stats_.check_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - check_start).count();
  return "";
}

}  // namespace rbdgrad::trajopt
