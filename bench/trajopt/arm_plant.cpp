// The in-process plant: see arm_plant.hpp.
#include "arm_plant.hpp"

#include <cmath>
#include <utility>

#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad::trajopt {

ArmPlant::ArmPlant(Model model, double dt) : model_(std::move(model)), ws_(model_), dt_(dt) {}

bool ArmPlant::step(const Eigen::VectorXd& x, const Eigen::VectorXd& tau, Eigen::VectorXd& next) {
  const int n = model_.nv;
  const Eigen::VectorXd q = x.head(n), qd = x.tail(n);
  if (!forward_dynamics(model_, ws_, q, qd, tau)) return false;
  next.resize(2 * n);
  next.tail(n) = qd + dt_ * ws_.qdd;
  next.head(n) = q + dt_ * next.tail(n);
  return next.allFinite();
}

Eigen::VectorXd ArmPlant::gravity_torque(const Eigen::VectorXd& q) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model_.nv);
  if (!rnea(model_, ws_, q, zero, zero)) return Eigen::VectorXd::Constant(model_.nv, std::nan(""));
  return ws_.tau;
}

bool ArmPlant::reference_derivatives(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& tau) {
  return static_cast<bool>(fd_derivatives(model_, ws_, q, qd, tau, InputKind::kTau));
}

}  // namespace rbdgrad::trajopt
