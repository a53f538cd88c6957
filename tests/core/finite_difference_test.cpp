// Tests for core/src/algorithm/fd_derivatives.cpp and rnea_derivatives.cpp against central finite
// differences on random chains and branching trees.
#include <gtest/gtest.h>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"

namespace rbdgrad {
namespace {

using testing::random_model;
using testing::random_vector;
using testing::TreeShape;

struct Case {
  int n;
  TreeShape shape;
  unsigned seed;
};

class FiniteDifference : public ::testing::TestWithParam<Case> {};

// Relative Frobenius error, with the denominator floored at 1e-3 of the pair's size and at 1e-4:
// some derivatives are exactly zero (root joints have d tau/d qd = 0, a prismatic root's qdd does
// not depend on q) and the differences' rounding noise (about 1e-12) is not error.
double pair_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref, const Eigen::MatrixXd& other_ref) {
  const double scale = std::max({ref.norm(), 1e-3 * std::hypot(ref.norm(), other_ref.norm()), 1e-4});
  return (x - ref).norm() / scale;
}

// Fourth-order central difference of a vector function along coordinate j of q or qd:
// (-f(+2h) + 8 f(+h) - 8 f(-h) + f(-2h)) / 12h, accurate to O(h^4) so h can stay large against rounding.
template <class F>
Eigen::MatrixXd difference_columns(int n, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, bool wrt_q, F f) {
  const double h = 1e-3;
  Eigen::MatrixXd out(n, n);
  for (int j = 0; j < n; ++j) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(n);
    for (const auto& [step, weight] : {std::pair{2, -1.0}, {1, 8.0}, {-1, -8.0}, {-2, 1.0}}) {
      Eigen::VectorXd qs = q, vs = qd;
      (wrt_q ? qs : vs)(j) += step * h;
      sum += weight * f(qs, vs);
    }
    out.col(j) = sum / (12 * h);
  }
  return out;
}

TEST_P(FiniteDifference, ForwardDynamicsGradientMatchesCentralDifferences) {
  const Case c = GetParam();
  const Model m = random_model(c.seed, c.n, c.shape);
  Workspace ws(m);
  std::mt19937 rng(c.seed * 7 + 1);
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd q = random_vector(rng, m.nv, 3.0), qd = random_vector(rng, m.nv, 2.0),
                          tau = random_vector(rng, m.nv, 5.0);
    const Eigen::VectorXd fext = random_vector(rng, 6 * m.nv, 2.0);
    const Eigen::VectorXd* forces = trial == 2 ? &fext : nullptr;
    ASSERT_TRUE(fd_derivatives(m, ws, q, qd, tau, InputKind::kTau, forces ? forces->data() : nullptr).is_ok());
    const Eigen::MatrixXd dq = ws.dqdd_dq, dqd = ws.dqdd_dqd;
    Workspace fd_ws(m);
    auto fd = [&](const Eigen::VectorXd& qs, const Eigen::VectorXd& vs) {
      EXPECT_TRUE(forward_dynamics(m, fd_ws, qs, vs, tau, forces ? forces->data() : nullptr).is_ok());
      return Eigen::VectorXd(fd_ws.qdd);
    };
    const Eigen::MatrixXd ref_dq = difference_columns(m.nv, q, qd, true, fd);
    const Eigen::MatrixXd ref_dqd = difference_columns(m.nv, q, qd, false, fd);
    EXPECT_LE(pair_error(dq, ref_dq, ref_dqd), 1e-6) << "n=" << c.n << " trial " << trial;
    EXPECT_LE(pair_error(dqd, ref_dqd, ref_dq), 1e-6) << "n=" << c.n << " trial " << trial;
  }
}

TEST_P(FiniteDifference, InverseDynamicsGradientMatchesCentralDifferences) {
  const Case c = GetParam();
  const Model m = random_model(c.seed + 1000, c.n, c.shape);
  Workspace ws(m);
  std::mt19937 rng(c.seed * 13 + 5);
  const Eigen::VectorXd q = random_vector(rng, m.nv, 3.0), qd = random_vector(rng, m.nv, 2.0),
                        qdd = random_vector(rng, m.nv, 4.0), fext = random_vector(rng, 6 * m.nv, 2.0);
  ASSERT_TRUE(rnea_derivatives(m, ws, q, qd, qdd, fext.data()).is_ok());
  const Eigen::MatrixXd dq = ws.dtau_dq, dqd = ws.dtau_dqd;
  Workspace w2(m);
  auto id = [&](const Eigen::VectorXd& qs, const Eigen::VectorXd& vs) {
    EXPECT_TRUE(rnea(m, w2, qs, vs, qdd, fext.data()).is_ok());
    return Eigen::VectorXd(w2.tau);
  };
  const Eigen::MatrixXd ref_dq = difference_columns(m.nv, q, qd, true, id);
  const Eigen::MatrixXd ref_dqd = difference_columns(m.nv, q, qd, false, id);
  EXPECT_LE(pair_error(dq, ref_dq, ref_dqd), 1e-6);
  EXPECT_LE(pair_error(dqd, ref_dqd, ref_dq), 1e-6);
}

std::vector<Case> cases() {
  std::vector<Case> out;
  unsigned seed = 1;
  for (int n : {2, 3, 5, 8, 13, 21, 34, 64}) {
    out.push_back({n, TreeShape::kChain, seed++});
    out.push_back({n, TreeShape::kBranching, seed++});
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(RandomTrees, FiniteDifference, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.shape == TreeShape::kChain ? "chain" : "tree") +
                                  std::to_string(p.param.n);
                         });

}  // namespace
}  // namespace rbdgrad
