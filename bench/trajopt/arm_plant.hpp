// The robot as the trajectory optimization sees it: x = (q, q̇), u = τ, stepped by semi-implicit
// (symplectic) Euler with q̈ from the core library in f64 — the true dynamics, computed in-process.
// Also the step's Jacobians from the derivatives of q̈, whoever computed those.
#pragma once

#include <Eigen/Core>

#include "rbdgrad/model.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::trajopt {

// q̇' = q̇ + dt q̈(q, q̇, τ), q' = q + dt q̇'. Semi-implicit rather than explicit Euler: it keeps the
// energy of the unactuated arm bounded at this step size, so the plant does not drift on its own.
class ArmPlant {
 public:
  ArmPlant(Model model, double dt);

  int nv() const { return model_.nv; }
  double dt() const { return dt_; }
  const Model& model() const { return model_; }

  /// x' = f(x, τ); false when the dynamics fail (not finite).
  bool step(const Eigen::VectorXd& x, const Eigen::VectorXd& tau, Eigen::VectorXd& next);
  /// The torque that holds the arm still at q: RNEA(q, 0, 0).
  Eigen::VectorXd gravity_torque(const Eigen::VectorXd& q);
  /// The reference derivatives at (q, q̇, τ) in f64 (the core library), to measure a backend's error:
  /// filled into the workspace's qdd, Minv, dqdd_dq, dqdd_dqd.
  bool reference_derivatives(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& tau);
  const Workspace& workspace() const { return ws_; }

 private:
  Model model_;
  Workspace ws_;
  double dt_;
};

/// The Jacobians of ArmPlant::step from ∂q̈/∂q, ∂q̈/∂q̇ and M⁻¹ (= ∂q̈/∂τ) at the same point:
///   ∂q̇'/∂(q, q̇, τ) = (dt ∂q̈/∂q, I + dt ∂q̈/∂q̇, dt M⁻¹), and q' = q + dt q̇' adds dt times that
///   to (I, 0, 0). A is 2nv x 2nv, B is 2nv x nv.
template <class Dq, class Dqd, class Minv>
void euler_jacobians(double dt, const Eigen::MatrixBase<Dq>& dqdd_dq, const Eigen::MatrixBase<Dqd>& dqdd_dqd,
                     const Eigen::MatrixBase<Minv>& minv, Eigen::MatrixXd& a, Eigen::MatrixXd& b) {
  const Eigen::Index n = dqdd_dq.rows();
  a.resize(2 * n, 2 * n);
  b.resize(2 * n, n);
  // velocity rows
  a.bottomLeftCorner(n, n) = dt * dqdd_dq.template cast<double>();
  a.bottomRightCorner(n, n) = dt * dqdd_dqd.template cast<double>();
  a.bottomRightCorner(n, n).diagonal().array() += 1.0;
  b.bottomRows(n) = dt * minv.template cast<double>();
  // position rows: I (on q) + dt times the velocity rows
  a.topRows(n) = dt * a.bottomRows(n);
  a.topLeftCorner(n, n).diagonal().array() += 1.0;
  b.topRows(n) = dt * b.bottomRows(n);
}

}  // namespace rbdgrad::trajopt
