// iLQR: see ilqr.hpp.
#include "ilqr.hpp"

#include <chrono>
#include <cmath>

#include <Eigen/Cholesky>

namespace rbdgrad::trajopt {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The affine control law of one backward pass: u_k = ū_k + α k_k + K_k (x_k − x̄_k).
struct Policy {
  std::vector<VectorXd> k;
  std::vector<MatrixXd> K;
  double dv1 = 0, dv2 = 0;  // predicted cost change for step α: α dv1 + α² dv2 (negative: a decrease)
};

// Rolls the plant out from x0 under the policy around `nominal` with step `alpha` (no policy:
// the nominal controls as they are). False when the plant failed or a state is not finite.
bool rollout(const Plant& plant, const VectorXd& x0, const Trajectory& nominal, const Policy* policy, double alpha,
             Trajectory& out) {
  const std::size_t horizon = nominal.u.size();
  out.x.resize(horizon + 1);
  out.u.resize(horizon);
  out.x[0] = x0;
  for (std::size_t i = 0; i < horizon; ++i) {
    out.u[i] = nominal.u[i];
    if (policy) out.u[i] += alpha * policy->k[i] + policy->K[i] * (out.x[i] - nominal.x[i]);
    if (!plant(out.x[i], out.u[i], out.x[i + 1]) || !out.x[i + 1].allFinite()) return false;
  }
  return true;
}

// The backward pass with regularization mu; false when some Q_uu + μ Bᵀ B is not positive definite.
bool backward_pass(const Trajectory& t, const Linearization& lin, const QuadraticCost& cost, double mu, Policy& p) {
  const std::size_t horizon = t.u.size();
  const Eigen::Index nx = t.x[0].size();
  p.k.resize(horizon);
  p.K.resize(horizon);
  p.dv1 = p.dv2 = 0;
  VectorXd vx = cost.qf_diag.cwiseProduct(t.x[horizon] - cost.x_goal);
  MatrixXd vxx = cost.qf_diag.asDiagonal();
  const MatrixXd mu_eye = mu * MatrixXd::Identity(nx, nx);
  for (std::size_t i = horizon; i-- > 0;) {
    const MatrixXd& a = lin.A[i];
    const MatrixXd& b = lin.B[i];
    const VectorXd qx = cost.q_diag.cwiseProduct(t.x[i] - cost.x_goal) + a.transpose() * vx;
    const VectorXd qu = cost.r_diag.cwiseProduct(t.u[i] - cost.u_ref) + b.transpose() * vx;
    MatrixXd qxx = a.transpose() * vxx * a;
    qxx.diagonal() += cost.q_diag;
    const MatrixXd vxx_b = vxx * b;
    MatrixXd quu = b.transpose() * vxx_b;
    quu.diagonal() += cost.r_diag;
    const MatrixXd qux = vxx_b.transpose() * a;
    // the regularized Q_uu and Q_ux give the policy; the plain ones the value function
    const MatrixXd vxx_reg_b = vxx_b + mu_eye * b;
    MatrixXd quu_reg = b.transpose() * vxx_reg_b;
    quu_reg.diagonal() += cost.r_diag;
    const MatrixXd qux_reg = vxx_reg_b.transpose() * a;
    const Eigen::LLT<MatrixXd> llt(quu_reg);
    if (llt.info() != Eigen::Success) return false;
    p.k[i] = -llt.solve(qu);
    p.K[i] = -llt.solve(qux_reg);
    const VectorXd& k = p.k[i];
    const MatrixXd& big_k = p.K[i];
    p.dv1 += k.dot(qu);
    p.dv2 += 0.5 * k.dot(quu * k);
    vx = qx + big_k.transpose() * (quu * k) + big_k.transpose() * qu + qux.transpose() * k;
    vxx = qxx + big_k.transpose() * quu * big_k + big_k.transpose() * qux + qux.transpose() * big_k;
    vxx = 0.5 * (vxx + vxx.transpose()).eval();
    if (!vx.allFinite() || !vxx.allFinite()) return false;
  }
  return true;
}

}  // namespace

double QuadraticCost::running(const VectorXd& x, const VectorXd& u) const {
  const VectorXd dx = x - x_goal, du = u - u_ref;
  return 0.5 * (dx.dot(q_diag.cwiseProduct(dx)) + du.dot(r_diag.cwiseProduct(du)));
}

double QuadraticCost::terminal(const VectorXd& x) const {
  const VectorXd dx = x - x_goal;
  return 0.5 * dx.dot(qf_diag.cwiseProduct(dx));
}

double QuadraticCost::total(const Trajectory& t) const {
  double sum = terminal(t.x.back());
  for (std::size_t i = 0; i < t.u.size(); ++i) sum += running(t.x[i], t.u[i]);
  return sum;
}

IlqrResult run_ilqr(const Plant& plant, const Linearize& linearize, const QuadraticCost& cost, const VectorXd& x0,
                    const std::vector<VectorXd>& u_init, const IlqrOptions& options, const Progress& progress) {
  IlqrResult r;
  Trajectory nominal;
  nominal.u = u_init;
  nominal.x.assign(u_init.size() + 1, x0);
  if (!rollout(plant, x0, nominal, nullptr, 0, r.trajectory)) {
    r.failed = true;
    r.stop_reason = "the initial rollout is not finite";
    return r;
  }
  double j = cost.total(r.trajectory);
  r.initial_cost = r.final_cost = j;
  double mu = options.mu_initial;
  Linearization lin;
  bool stale = true;  // the linearization is not of r.trajectory (a failed line search keeps it)
  Policy policy;
  Trajectory candidate;
  r.stop_reason = "max iterations";
  for (int it = 1; it <= options.max_iterations; ++it) {
    r.iterations = it;
    IlqrIteration rec;
    rec.iteration = it;
    if (stale) {
      const auto start = std::chrono::steady_clock::now();
      if (std::string error = linearize(r.trajectory, lin); !error.empty()) {
        r.failed = true;
        r.stop_reason = error;
        break;
      }
      rec.linearize_s = seconds_since(start);
      r.linearize_s += rec.linearize_s;
      stale = false;
    }
    bool gave_up = false;
    while (!backward_pass(r.trajectory, lin, cost, mu, policy)) {
      mu = std::max(mu * options.mu_factor, options.mu_min);
      if (mu > options.mu_max) {
        gave_up = true;
        break;
      }
    }
    if (gave_up) {
      r.stop_reason = "regularization limit (Q_uu not positive definite)";
      break;
    }
    rec.mu = mu;
    // what the linearization promises for a full step: nothing left to gain is convergence
    const double predicted = -(policy.dv1 + policy.dv2);
    if (predicted < options.tolerance * j) {
      rec.cost = j;
      rec.expected = predicted;
      if (progress) progress(rec);
      r.converged = true;
      r.stop_reason = "converged (predicted decrease below tolerance)";
      break;
    }
    for (double alpha = 1; alpha >= options.alpha_min; alpha *= 0.5) {
      if (!rollout(plant, x0, r.trajectory, &policy, alpha, candidate)) continue;
      const double jn = cost.total(candidate);
      const double expected = -(alpha * policy.dv1 + alpha * alpha * policy.dv2);
      if (j - jn > 0 && j - jn >= options.accept_ratio * expected) {
        rec.alpha = alpha;
        rec.expected = expected;
        rec.actual = j - jn;
        break;
      }
    }
    if (rec.alpha > 0) {
      std::swap(r.trajectory, candidate);
      j = cost.total(r.trajectory);
      stale = true;
      mu = std::max(mu / options.mu_factor, options.mu_min);
    } else {
      mu = std::max(mu * options.mu_factor, options.mu_min);
    }
    rec.cost = j;
    if (progress) progress(rec);
    if (rec.alpha > 0 && rec.actual < options.tolerance * (j + rec.actual)) {
      r.converged = true;
      r.stop_reason = "converged (relative decrease below tolerance)";
      break;
    }
    if (mu > options.mu_max) {
      r.stop_reason = "regularization limit (no step lowers the cost)";
      break;
    }
  }
  r.final_cost = j;
  return r;
}

}  // namespace rbdgrad::trajopt
