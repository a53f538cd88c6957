// The iiwa14 reaching task: see reach_task.hpp.
#include "reach_task.hpp"

namespace rbdgrad::trajopt {

ReachTask iiwa14_reach_task(bool quick) {
  ReachTask t;
  if (quick) t.horizon = 50;
  t.q0.resize(7);
  t.q_goal.resize(7);
  // a bent, elbow-up pose to another one, every joint moving (limits ±2.97, ±2.09, ±2.97, ±2.09,
  // ±2.97, ±2.09, ±3.05 rad), away from singular stretched poses
  t.q0 << 0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0;
  t.q_goal << 0.6, 1.0, -0.5, -1.8, 0.6, 0.2, 0.7;
  return t;
}

QuadraticCost reach_cost(const ReachTask& task, const Eigen::VectorXd& goal_torque) {
  const Eigen::Index n = task.q_goal.size();
  QuadraticCost c;
  c.x_goal = Eigen::VectorXd::Zero(2 * n);
  c.x_goal.head(n) = task.q_goal;
  c.u_ref = goal_torque;
  c.q_diag.resize(2 * n);
  c.q_diag << Eigen::VectorXd::Constant(n, task.w_q * task.dt), Eigen::VectorXd::Constant(n, task.w_qd * task.dt);
  c.r_diag = Eigen::VectorXd::Constant(n, task.w_tau * task.dt);
  c.qf_diag.resize(2 * n);
  c.qf_diag << Eigen::VectorXd::Constant(n, task.w_q_final), Eigen::VectorXd::Constant(n, task.w_qd_final);
  return c;
}

}  // namespace rbdgrad::trajopt
