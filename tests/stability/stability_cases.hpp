// What the numerical-stability sweeps vary (issue 7): the model (link mass and inertia ratios,
// gravity) and the state (joint speed, closeness to the joint limits or to a kinematic singularity).
// Shared by the fast tests (tests/stability) and the long sweeps (bench/stability).
#pragma once

#include <cmath>
#include <numbers>
#include <random>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad::stability {

// One input state; tau is the input of fd_derivatives (InputKind::kTau).
struct StateInput {
  Eigen::VectorXd q, qd, tau;
};

enum class Scaling {
  kMassAndInertia,  // mass and rotational inertia together: a denser or lighter link
  kInertia,         // rotational inertia about the centre of mass only: a more or less compact link
};

// Link i scaled by ratio^((depth_i - 1) / (max_depth - 1)): a geometric progression along every
// branch, so the deepest links carry `ratio` times the root link's mass (or inertia).
inline Model with_link_ratio(Model m, double ratio, Scaling what) {
  const int max_depth = m.max_depth();
  for (int i = 0; i < m.nv; ++i) {
    const double t = max_depth > 1 ? static_cast<double>(m.depth[static_cast<size_t>(i)] - 1) / (max_depth - 1) : 0;
    const double s = std::pow(ratio, t);
    if (what == Scaling::kMassAndInertia) m.mass[static_cast<size_t>(i)] *= s;
    m.inertia_com[static_cast<size_t>(i)] *= s;
  }
  return m;
}

inline Model with_gravity(Model m, bool on) {
  if (!on) m.gravity.setZero();
  return m;
}

inline bool has_limits(const JointInfo& j) { return j.lower_limit < j.upper_limit; }

// Uniform within the joint limits; +-pi for a joint without limits (random test trees, continuous).
inline Eigen::VectorXd random_configuration(const Model& m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::VectorXd q(m.nv);
  for (int i = 0; i < m.nv; ++i) {
    const JointInfo& j = m.joints[static_cast<size_t>(i)];
    const double lo = has_limits(j) ? j.lower_limit : -std::numbers::pi, hi = has_limits(j) ? j.upper_limit : std::numbers::pi;
    q(i) = lo + (hi - lo) * u(rng);
  }
  return q;
}

// Each joint with limits at `fraction` of its range inside a randomly chosen limit (0: at the limit);
// joints without limits at random.
inline Eigen::VectorXd configuration_near_limits(const Model& m, std::mt19937& rng, double fraction) {
  Eigen::VectorXd q = random_configuration(m, rng);
  std::bernoulli_distribution upper(0.5);
  for (int i = 0; i < m.nv; ++i) {
    const JointInfo& j = m.joints[static_cast<size_t>(i)];
    if (!has_limits(j)) continue;
    const double d = fraction * (j.upper_limit - j.lower_limit);
    q(i) = upper(rng) ? j.upper_limit - d : j.lower_limit + d;
  }
  return q;
}

// q = 0 plus a random perturbation of size up to eps: on iiwa14 q = 0 is the arm stretched out,
// axes 1, 3, 5 and 7 in line (a kinematic singularity).
inline Eigen::VectorXd configuration_near_zero(std::mt19937& rng, int n, double eps) {
  return testing::random_vector(rng, n, 1) * eps;
}

// A random direction scaled so that the fastest joint moves at exactly `speed` (rad/s or m/s).
inline Eigen::VectorXd velocity_with_max(std::mt19937& rng, int n, double speed) {
  Eigen::VectorXd qd = testing::random_vector(rng, n, 1);
  return qd * (speed / qd.cwiseAbs().maxCoeff());
}

// tau that gives a moderate acceleration (|qdd_i| <= 1) at (q, qd): the torques a controller would
// command, so that large speeds show up as Coriolis terms rather than as huge accelerations.
inline Eigen::VectorXd torque_for_moderate_acceleration(const Model& m, std::mt19937& rng, const Eigen::VectorXd& q,
                                                        const Eigen::VectorXd& qd) {
  Workspace ws(m);
  const Eigen::VectorXd qdd = testing::random_vector(rng, m.nv, 1);
  if (Status s = rnea(m, ws, q, qd, qdd); !s) throw std::runtime_error(s.to_string());
  return ws.tau;
}

}  // namespace rbdgrad::stability
