// Tests for core/src/execution_plan.cpp: the body mask, the plan of a request, the checks of a plan
// against a model and a request, and the dispatch from a plan to its stage set.
#include "rbdgrad/execution_plan.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {
namespace {

std::vector<int> bodies(const BodyMask& m, int nv) {
  std::vector<int> out;
  m.for_each(nv, [&](int b) { out.push_back(b); });
  return out;
}

TEST(BodyMask, HoldsBodiesAcrossWordsInOrder) {
  BodyMask m;
  EXPECT_TRUE(m.empty());
  for (int b : {200, 3, 64, 63, 0, 255}) EXPECT_TRUE(m.set(b));
  EXPECT_FALSE(m.set(BodyMask::kCapacity));
  EXPECT_FALSE(m.set(-1));
  EXPECT_EQ(m.count(), 6);
  EXPECT_TRUE(m.test(63));
  EXPECT_TRUE(m.test(64));
  EXPECT_FALSE(m.test(65));
  EXPECT_EQ(bodies(m, 256), (std::vector<int>{0, 3, 63, 64, 200, 255}));
  // a model of nv bodies sees only bodies below nv, also when nv ends inside a word
  EXPECT_EQ(bodies(m, 64), (std::vector<int>{0, 3, 63}));
  EXPECT_EQ(bodies(m, 65), (std::vector<int>{0, 3, 63, 64}));
  EXPECT_EQ(bodies(m, 4), (std::vector<int>{0, 3}));
  EXPECT_EQ(m.first_at_or_above(4), 63);
  EXPECT_EQ(m.first_at_or_above(65), 200);
  EXPECT_EQ(m.first_at_or_above(256), -1);
  EXPECT_EQ(m.first_at_or_above(1000), -1);
}

TEST(PlanRequest, FollowsTheOutputsTheForcesTheInverseAndTheGravity) {
  Model iiwa = testing::load_embedded("iiwa14");
  const double fext[6] = {};
  const Eigen::MatrixXd minv = Eigen::MatrixXd::Identity(iiwa.nv, iiwa.nv);
  ExecutionPlan p = plan_request(iiwa, kOutputDqddDq, nullptr, nullptr);
  EXPECT_TRUE(p.dqdd_dq);
  EXPECT_FALSE(p.dqdd_dqd);
  EXPECT_TRUE(p.gravity);
  EXPECT_EQ(p.external_forces, ExternalForces::kNone);
  EXPECT_FALSE(p.minv_supplied);
  p = plan_request(iiwa, kOutputDqddDqd | kOutputQdd, fext, &minv);
  EXPECT_FALSE(p.dqdd_dq);
  EXPECT_TRUE(p.dqdd_dqd);
  EXPECT_EQ(p.external_forces, ExternalForces::kAllBodies);
  EXPECT_TRUE(p.minv_supplied);
  EXPECT_EQ(gradient_stages(p), (GradientStages{false, true, true}));
  // outputs without a d qdd column: the gradient stages are none
  p = plan_request(iiwa, kOutputMinv | kOutputDtauDq, nullptr, nullptr);
  EXPECT_FALSE(p.dqdd_dq || p.dqdd_dqd);
  iiwa.gravity.setZero();
  EXPECT_FALSE(plan_request(iiwa, kAllOutputs, nullptr, nullptr).gravity);
  EXPECT_FALSE(plan_request(iiwa.cast<float>(), kAllOutputs, nullptr, nullptr).gravity);
  EXPECT_TRUE(plan_request(testing::load_embedded("hyq").cast<Q16_16>(), kAllOutputs, nullptr, nullptr).gravity);
}

TEST(CheckPlan, RefusesPlansTheModelOrTheRequestCannotMeet) {
  ExecutionPlan p;
  EXPECT_TRUE(check_plan(7, p, false, false));
  p.external_forces = ExternalForces::kAllBodies;
  Status s = check_plan(7, p, false, false);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("fext is null"), std::string::npos) << s.message();
  p.external_forces = ExternalForces::kSomeBodies;
  p.fext_bodies.set(2);
  p.fext_bodies.set(7);
  s = check_plan(7, p, true, false);
  EXPECT_NE(s.message().find("body 7 but the model has 7 bodies"), std::string::npos) << s.message();
  EXPECT_TRUE(check_plan(8, p, true, false));
  p.minv_supplied = true;
  s = check_plan(8, p, true, false);
  EXPECT_NE(s.message().find("M^-1 from the caller"), std::string::npos) << s.message();

  // the algorithms refuse such a plan before computing anything
  const Model iiwa = testing::load_embedded("iiwa14");
  Workspace ws(iiwa);
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(iiwa.nv, 0.3);
  ExecutionPlan forces;
  forces.external_forces = ExternalForces::kAllBodies;
  EXPECT_EQ(fd_derivatives(iiwa, ws, x, x, x, InputKind::kTau, forces, nullptr, nullptr).code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(rnea(iiwa, ws, x, x, x, forces, nullptr).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(forward_dynamics(iiwa, ws, x, x, x, forces, nullptr).code(), StatusCode::kInvalidArgument);
  // a plan without d qdd/d q cannot serve a request for it
  ExecutionPlan dqd_only;
  dqd_only.dqdd_dq = false;
  s = evaluate_outputs(iiwa, ws, x, x, x, InputKind::kTau, kOutputDqddDq, dqd_only, nullptr, nullptr);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("excludes a requested d qdd column"), std::string::npos) << s.message();
}

TEST(DispatchStages, CallsTheInstantiationOfThePlansStages) {
  for (int i = 0; i < kNumStageSets; ++i) {
    const GradientStages want = stage_set(i);
    EXPECT_EQ(stage_index(want), i);
    int calls = 0;
    const Status s = dispatch_stages(want, [&]<GradientStages kStages>() {
      ++calls;
      return kStages == want ? Status::ok() : invalid_argument("another stage set");
    });
    EXPECT_TRUE(s) << i;
    EXPECT_EQ(calls, 1) << i;
  }
}

}  // namespace
}  // namespace rbdgrad
