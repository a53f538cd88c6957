// Tests for core/src/algorithm/{crba,minverse,forward_dynamics,rnea}.cpp: identities that must hold
// on any model, checked on random trees and the shipped robots.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"

namespace rbdgrad {
namespace {

std::vector<Model> models() {
  std::vector<Model> out;
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) out.push_back(testing::load_embedded(robot));
  out.push_back(testing::random_model(11, 17, testing::TreeShape::kBranching));
  out.push_back(testing::random_model(12, 40, testing::TreeShape::kChain));
  return out;
}

TEST(Identities, MassMatrixIsSymmetricPositiveDefiniteAndMinvIsItsInverse) {
  for (const Model& m : models()) {
    Workspace ws(m);
    std::mt19937 rng(3);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::VectorXd q = testing::random_vector(rng, m.nv, 3.0);
      ASSERT_TRUE(minverse(m, ws, q).is_ok()) << m.name;
      EXPECT_EQ((ws.M - ws.M.transpose()).norm(), 0.0) << m.name;
      const Eigen::VectorXd eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(ws.M).eigenvalues();
      EXPECT_GT(eig.minCoeff(), 0.0) << m.name;
      const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(m.nv, m.nv);
      // the residual grows with cond(M); 1e-9 leaves margin for cond up to ~1e6
      EXPECT_LE((ws.M * ws.Minv - I).norm(), 1e-9) << m.name;
      EXPECT_LE((ws.Minv - ws.Minv.transpose()).norm(), 1e-12 * ws.Minv.norm()) << m.name;
    }
  }
}

TEST(Identities, ForwardDynamicsInvertsInverseDynamics) {
  for (const Model& m : models()) {
    Workspace ws(m);
    std::mt19937 rng(4);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::VectorXd q = testing::random_vector(rng, m.nv, 3.0), qd = testing::random_vector(rng, m.nv, 2.0),
                            qdd = testing::random_vector(rng, m.nv, 4.0),
                            fext = testing::random_vector(rng, 6 * m.nv, 1.0);
      const double* forces = trial % 2 ? fext.data() : nullptr;
      ASSERT_TRUE(rnea(m, ws, q, qd, qdd, forces).is_ok());
      const Eigen::VectorXd tau = ws.tau;
      ASSERT_TRUE(forward_dynamics(m, ws, q, qd, tau, forces).is_ok());
      EXPECT_LE((ws.qdd - qdd).norm(), 1e-9 * (1 + qdd.norm())) << m.name;
    }
  }
}

TEST(Identities, GradientFromTauEqualsGradientFromQdd) {
  // Algorithm 3 with tau as input computes qdd first; both routes must give the same gradient
  for (const Model& m : models()) {
    Workspace ws(m);
    std::mt19937 rng(5);
    const Eigen::VectorXd q = testing::random_vector(rng, m.nv, 3.0), qd = testing::random_vector(rng, m.nv, 2.0),
                          tau = testing::random_vector(rng, m.nv, 5.0);
    ASSERT_TRUE(fd_derivatives(m, ws, q, qd, tau, InputKind::kTau).is_ok());
    const Eigen::MatrixXd dq = ws.dqdd_dq, dqd = ws.dqdd_dqd, Minv = ws.Minv;
    const Eigen::VectorXd qdd = ws.qdd;
    // and with the caller's M^-1 instead of a computed one
    ASSERT_TRUE(fd_derivatives(m, ws, q, qd, qdd, InputKind::kQdd, nullptr, &Minv).is_ok());
    EXPECT_LE(testing::relative_error(ws.dqdd_dq, dq), 1e-10) << m.name;
    EXPECT_LE(testing::relative_error(ws.dqdd_dqd, dqd), 1e-10) << m.name;
    EXPECT_LE((ws.tau - tau).norm(), 1e-9 * (1 + tau.norm())) << m.name;
  }
}

}  // namespace
}  // namespace rbdgrad
