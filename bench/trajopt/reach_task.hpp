// The task: move the iiwa14 from rest at q0 to rest at q_goal in about a second — its horizon,
// cost weights and what counts as reaching the goal, all fixed before any run.
#pragma once

#include <Eigen/Core>

#include "ilqr.hpp"

namespace rbdgrad::trajopt {

struct ReachTask {
  // 10 ms is a usual rate for trajectory optimization and MPC of an arm, and fine enough for the
  // semi-implicit Euler step on iiwa14; 100 steps (1 s) let moves of 0.5-0.7 rad per joint stay
  // below every joint's velocity limit (1.31-2.36 rad/s) without constraints: the optimum peaks at
  // about 80% of it (max_qd_over_limit in the CSV)
  double dt = 0.01;
  int horizon = 100;
  Eigen::VectorXd q0, q_goal;  // (7) rad, inside the joint limits

  // weights per unit of time on the running terms (multiplied by dt per step)
  double w_q = 0.1;     // (rad)^-2 s^-1: a small pull toward the goal along the way (at 1, the
                        // arm hurries and exceeds a velocity limit by 18%)
  double w_qd = 0.1;    // (rad/s)^-2 s^-1
  double w_tau = 1e-3;  // (N m)^-2 s^-1, on τ minus the torque that holds the arm at the goal, so
                        // that resting at the goal costs nothing and only the gradients limit how
                        // close the optimizer gets
  // terminal weights: large, so that the goal dominates
  double w_q_final = 1e4;   // (rad)^-2
  double w_qd_final = 1e3;  // (rad/s)^-2

  // reached: ‖q_T − q_goal‖ below goal_q_tol and ‖q̇_T‖ below goal_qd_tol (decided before any run:
  // 1e-2 rad is about 1 cm at the flange of this 1.3 m arm)
  double goal_q_tol = 1e-2;   // rad
  double goal_qd_tol = 1e-1;  // rad/s
};

/// The iiwa14 task; quick: a horizon of 50 steps (0.5 s) for a smoke test.
ReachTask iiwa14_reach_task(bool quick);

/// The cost of `task` for x = (q, q̇), u = τ; goal_torque = RNEA(q_goal, 0, 0).
QuadraticCost reach_cost(const ReachTask& task, const Eigen::VectorXd& goal_torque);

}  // namespace rbdgrad::trajopt
