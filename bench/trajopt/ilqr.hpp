// iLQR (Li & Todorov 2004, with the regularization and line search of Tassa, Erez & Todorov 2012)
// over a quadratic cost, with the two halves of the dynamics kept apart: the rollouts step the
// true dynamics (Plant), the backward pass uses a linearization from elsewhere (Linearize), e.g. a
// backend in a lower precision. The optimizer is the same either way, so a difference in the
// outcome is the gradients' doing.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rbdgrad::trajopt {

// States x_0..x_T and controls u_0..u_{T-1}.
struct Trajectory {
  std::vector<Eigen::VectorXd> x;  // (T + 1) x nx
  std::vector<Eigen::VectorXd> u;  // T x nu
};

// x_{k+1} ≈ x̄_{k+1} + A_k (x_k − x̄_k) + B_k (u_k − ū_k) around a trajectory.
struct Linearization {
  std::vector<Eigen::MatrixXd> A;  // T x (nx x nx)
  std::vector<Eigen::MatrixXd> B;  // T x (nx x nu)
};

// l(x, u) = ½ (x − x_goal)ᵀ Q (x − x_goal) + ½ (u − u_ref)ᵀ R (u − u_ref) per step,
// l_T(x) = ½ (x − x_goal)ᵀ Qf (x − x_goal) at the end; diagonal weights.
struct QuadraticCost {
  Eigen::VectorXd x_goal, u_ref;
  Eigen::VectorXd q_diag, r_diag, qf_diag;

  double running(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const;
  double terminal(const Eigen::VectorXd& x) const;
  double total(const Trajectory& t) const;
};

struct IlqrOptions {
  int max_iterations = 100;
  // converged when an accepted step lowers the cost by less than this fraction of it, or the
  // backward pass predicts less than that
  double tolerance = 1e-6;
  // Levenberg-Marquardt term μ on V_xx (Tassa's state regularization): raised when Q_uu is not
  // positive definite or no step of the line search is accepted, lowered after a success; the
  // optimizer gives up above mu_max
  double mu_initial = 1e-6, mu_min = 1e-9, mu_max = 1e10, mu_factor = 10;
  // step sizes α tried, halving from 1 down to this
  double alpha_min = 1.0 / 1024;
  // accept a step when its actual decrease is at least this fraction of the predicted one
  double accept_ratio = 1e-4;
};

// What one iteration did (for the progress line).
struct IlqrIteration {
  int iteration = 0;      // 1-based
  double cost = 0;        // after the iteration
  double alpha = 0;       // the step accepted, 0 = none
  double mu = 0;          // the regularization used
  double expected = 0;    // predicted decrease for alpha (0: none accepted); converged: for α = 1
  double actual = 0;      // actual decrease
  double linearize_s = 0; // time in the Linearize call
};

struct IlqrResult {
  Trajectory trajectory;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;  // linearizations done
  bool converged = false;
  std::string stop_reason;  // "converged: ...", "max iterations", "regularization limit", or an error
  bool failed = false;      // the linearization failed (stop_reason says why)
  double linearize_s = 0;   // total time in Linearize calls
};

// x_{k+1} = step(x_k, u_k), the true dynamics; false when it cannot be computed (non-finite).
using Plant = std::function<bool(const Eigen::VectorXd& x, const Eigen::VectorXd& u, Eigen::VectorXd& next)>;
// Fills the linearization of every step of `t`; returns "" or the problem.
using Linearize = std::function<std::string(const Trajectory& t, Linearization& out)>;
using Progress = std::function<void(const IlqrIteration&)>;

/// Optimizes u from x0 and the initial controls `u_init` (T of them).
IlqrResult run_ilqr(const Plant& plant, const Linearize& linearize, const QuadraticCost& cost,
                    const Eigen::VectorXd& x0, const std::vector<Eigen::VectorXd>& u_init,
                    const IlqrOptions& options, const Progress& progress = {});

}  // namespace rbdgrad::trajopt
