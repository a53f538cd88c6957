// Tests for core/src/locked_joints.cpp: a model with joints held fixed has exactly the full
// model's mass matrix and bias forces in the kept joints (locked joints at their values and at
// rest), so its dynamics and their derivatives are the full model's restricted to the kept
// joints; and bad lock lists are refused, naming the joint.
#include "rbdgrad/locked_joints.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/crba.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad {
namespace {

using testing::relative_error;

// The full model with the locked joints at their values and at rest: its M and bias forces
// (RNEA at q̈ = 0) restricted to the kept joints, at a state of the kept joints.
class HeldModel {
 public:
  HeldModel(const Model& full, const std::vector<LockedJoint>& locked, std::vector<int> kept)
      : full_(full), ws_(full), kept_(std::move(kept)), q_(Eigen::VectorXd::Zero(full.nv)) {
    for (const LockedJoint& l : locked)
      for (int i = 0; i < full.nv; ++i)
        if (full.joints[static_cast<std::size_t>(i)].name == l.name) q_(i) = l.value;
  }

  void restricted(const Eigen::VectorXd& q_kept, const Eigen::VectorXd& qd_kept, Eigen::MatrixXd& M, Eigen::VectorXd& c) {
    Eigen::VectorXd q = q_, qd = Eigen::VectorXd::Zero(full_.nv);
    const auto n = static_cast<int>(kept_.size());
    for (int k = 0; k < n; ++k) {
      q(at(k)) = q_kept(k);
      qd(at(k)) = qd_kept(k);
    }
    EXPECT_TRUE(crba(full_, ws_, q));
    EXPECT_TRUE(rnea(full_, ws_, q, qd, Eigen::VectorXd::Zero(full_.nv)));
    M.resize(n, n);
    c.resize(n);
    for (int a = 0; a < n; ++a) {
      c(a) = ws_.tau(at(a));
      for (int b = 0; b < n; ++b) M(a, b) = ws_.M(at(a), at(b));
    }
  }

 private:
  int at(int k) const { return kept_[static_cast<std::size_t>(k)]; }
  const Model& full_;
  Workspace ws_;
  std::vector<int> kept_;
  Eigen::VectorXd q_;  // the locked joints' values, zero elsewhere
};

// Compares, at random states of the kept joints, the reduced model's M, bias forces and forward
// dynamics with the full model's rows and columns of the kept joints.
void expect_restriction(const Model& full, const std::vector<LockedJoint>& locked, unsigned seed) {
  Model reduced;
  std::vector<int> kept;
  const Status s = lock_joints(full, locked, reduced, &kept);
  ASSERT_TRUE(s) << s.to_string();
  ASSERT_EQ(reduced.nv, full.nv - static_cast<int>(locked.size()));
  ASSERT_EQ(kept.size(), static_cast<std::size_t>(reduced.nv));
  std::vector<bool> is_locked(static_cast<std::size_t>(full.nv), false);
  for (const LockedJoint& l : locked)
    for (int i = 0; i < full.nv; ++i)
      if (full.joints[static_cast<std::size_t>(i)].name == l.name) is_locked[static_cast<std::size_t>(i)] = true;
  for (int k = 0; k < reduced.nv; ++k) {
    EXPECT_FALSE(is_locked[static_cast<std::size_t>(kept[static_cast<std::size_t>(k)])]);
    EXPECT_EQ(reduced.joints[static_cast<std::size_t>(k)].name, full.joints[static_cast<std::size_t>(kept[k])].name);
  }
  HeldModel held(full, locked, kept);
  Workspace wr(reduced);
  std::mt19937 rng(seed);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd qr = testing::random_vector(rng, reduced.nv, 1.5);
    const Eigen::VectorXd qdr = testing::random_vector(rng, reduced.nv, 2.0);
    const Eigen::VectorXd taur = testing::random_vector(rng, reduced.nv, 5.0);
    Eigen::MatrixXd Mk;
    Eigen::VectorXd ck;
    held.restricted(qr, qdr, Mk, ck);
    ASSERT_TRUE(crba(reduced, wr, qr));
    EXPECT_LT(relative_error(wr.M, Mk), 1e-12) << "trial " << trial;
    ASSERT_TRUE(rnea(reduced, wr, qr, qdr, Eigen::VectorXd::Zero(reduced.nv)));
    EXPECT_LT(relative_error(wr.tau, ck), 1e-12) << "trial " << trial;
    // the dynamics with the locked joints held: M_kk qdd = tau - c_k
    ASSERT_TRUE(forward_dynamics(reduced, wr, qr, qdr, taur));
    const Eigen::VectorXd qdd = Mk.ldlt().solve(taur - ck);
    EXPECT_LT(relative_error(wr.qdd, qdd), 1e-10) << "trial " << trial;
  }
}

TEST(LockJoints, IiwaWristLockedIsTheArmsRestriction) {
  const Model iiwa = testing::load_embedded("iiwa14");
  expect_restriction(iiwa, {{"iiwa_joint_5", 0.4}, {"iiwa_joint_6", -1.1}, {"iiwa_joint_7", 2.0}}, 1);
  // a joint in the middle: its child hangs from joint 3's body through the locked transform
  expect_restriction(iiwa, {{"iiwa_joint_4", -1.2}}, 2);
  // the first joint: its body is fixed to the world and drops out
  expect_restriction(iiwa, {{"iiwa_joint_1", 0.7}}, 3);
}

TEST(LockJoints, BranchingTreesAndPrismaticJoints) {
  const Model hyq = testing::load_embedded("hyq");
  // hyq's first leg: its middle joint, so its last joint hangs from the first one's body
  expect_restriction(hyq, {{hyq.joints[1].name, 0.3}}, 4);
  for (unsigned seed = 10; seed < 16; ++seed) {
    const Model tree = testing::random_model(seed, 12, testing::TreeShape::kBranching, /*with_prismatic=*/true);
    // a chain of consecutive locks, a root and a prismatic joint when there is one
    std::vector<LockedJoint> locked = {{tree.joints[0].name, 0.2}, {tree.joints[5].name, -0.3},
                                       {tree.joints[6].name, 0.25}};
    for (int i = 7; i < tree.nv; ++i)
      if (tree.type[static_cast<std::size_t>(i)] == JointType::kPrismatic) {
        locked.push_back({tree.joints[static_cast<std::size_t>(i)].name, 0.1});
        break;
      }
    expect_restriction(tree, locked, seed);
  }
}

TEST(LockJoints, GradientsAreTheRestrictedOnes) {
  // talos_reduced with the head and the left arm's last joints locked: fd_derivatives on the
  // reduced model against central differences of the full model's held dynamics
  const Model talos = testing::load_embedded("talos_reduced");
  std::vector<LockedJoint> locked;
  for (const JointInfo& j : talos.joints)
    if (j.name.find("head") != std::string::npos) locked.push_back({j.name, 0.1});
  ASSERT_FALSE(locked.empty());
  Model reduced;
  std::vector<int> kept;
  ASSERT_TRUE(lock_joints(talos, locked, reduced, &kept));
  EXPECT_EQ(reduced.nv, talos.nv - static_cast<int>(locked.size()));
  std::mt19937 rng(7);
  const Eigen::VectorXd q = testing::random_vector(rng, reduced.nv, 1.0), qd = testing::random_vector(rng, reduced.nv, 1.0),
                        tau = testing::random_vector(rng, reduced.nv, 5.0);
  Workspace wr(reduced);
  ASSERT_TRUE(fd_derivatives(reduced, wr, q, qd, tau, InputKind::kTau));
  const Eigen::MatrixXd dq = wr.dqdd_dq;
  // the held dynamics of the full model, qdd_k(q_k) = M_kk^-1 (tau - c_k)
  HeldModel held(talos, locked, kept);
  const auto held_qdd = [&](const Eigen::VectorXd& qk) {
    Eigen::MatrixXd M;
    Eigen::VectorXd c;
    held.restricted(qk, qd, M, c);
    return Eigen::VectorXd(M.ldlt().solve(tau - c));
  };
  Eigen::MatrixXd fd(reduced.nv, reduced.nv);
  const double h = 1e-6;
  for (int j = 0; j < reduced.nv; ++j) {
    Eigen::VectorXd qp = q, qm = q;
    qp(j) += h;
    qm(j) -= h;
    fd.col(j) = (held_qdd(qp) - held_qdd(qm)) / (2 * h);
  }
  EXPECT_LT(relative_error(dq, fd), 1e-6);
}

TEST(LockJoints, BadListsAreRefusedNamingTheJoint) {
  const Model iiwa = testing::load_embedded("iiwa14");
  Model out;
  const auto refused = [&](const std::vector<LockedJoint>& locked, const std::string& want) {
    const Status s = lock_joints(iiwa, locked, out);
    EXPECT_FALSE(s);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find(want), std::string::npos) << s.message();
  };
  refused({{"wrist", 0}}, "locked joint 'wrist': model 'iiwa14' has no such joint");
  refused({{"iiwa_joint_2", 0}, {"iiwa_joint_2", 0.1}}, "'iiwa_joint_2' is named twice");
  refused({{"iiwa_joint_2", 2.5}}, "value 2.5 is outside its limits [-2.0944, 2.0944]");
  refused({{"iiwa_joint_3", std::numeric_limits<double>::quiet_NaN()}}, "value is not finite");
  std::vector<LockedJoint> all;
  for (const JointInfo& j : iiwa.joints) all.push_back({j.name, 0});
  refused(all, "leaves nothing to move");
  // nothing locked: the same model
  ASSERT_TRUE(lock_joints(iiwa, {}, out));
  EXPECT_EQ(out.nv, iiwa.nv);
}

}  // namespace
}  // namespace rbdgrad
