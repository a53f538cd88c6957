// What a linearizer (daemon_linearizer.hpp, kernel_linearizer.hpp) reports about its run: time in
// the gradient computation, and how far its outputs are from the core library's f64 at the same
// states — the same measures whichever computed them, so the runs' rows compare.
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

namespace rbdgrad::trajopt {

struct LinearizerStats {
  int calls = 0;
  double gradient_s = 0;         // the daemon's Compute calls end to end, or the kernel's runs
  double server_compute_s = 0;   // of which in the backend (the whole of it in-process)
  std::uint64_t states = 0;
  std::uint64_t fallback_states = 0;  // daemon fixed point: states the server computed again in floating point
  std::uint64_t overflowed_states = 0;  // kernel: flagged states of the call that stopped the run
  std::string backend_mode;      // "" or "csim", as the responses say; "host" for the kernel
  // worst relative Frobenius error per state against the core library's f64, over every state computed
  double max_grad_error = 0;     // of [∂q̈/∂q ∂q̈/∂q̇]
  double max_minv_error = 0;     // of M⁻¹
  double check_s = 0;            // time spent on that comparison (not part of the optimization)
};

inline double relative_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref) {
  const double denom = ref.norm();
  return denom > 0 ? (x - ref).norm() / denom : (x - ref).norm();
}

// Of the state's whole Jacobian [∂q̈/∂q ∂q̈/∂q̇], not of each half: at rest ∂q̈/∂q̇ is zero up to
// rounding (it is linear in q̇), and the error of a near-zero matrix relative to itself says nothing.
inline double jacobian_error(const Eigen::MatrixXd& dq, const Eigen::MatrixXd& dqd, const Eigen::MatrixXd& ref_dq,
                             const Eigen::MatrixXd& ref_dqd) {
  Eigen::MatrixXd x(dq.rows(), dq.cols() + dqd.cols()), ref(x.rows(), x.cols());
  x << dq, dqd;
  ref << ref_dq, ref_dqd;
  return relative_error(x, ref);
}

}  // namespace rbdgrad::trajopt
