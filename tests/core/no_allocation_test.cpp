// Tests that no core algorithm allocates on the heap once its workspace exists (STYLE.md point 5).
// Own executable: it replaces the global operator new to count allocations.
#include <gtest/gtest.h>

#include "../support/counting_new.hpp"

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {
namespace {

template <class S>
void expect_no_allocation(const std::string& robot) {
  const ModelTpl<S> m = testing::load_embedded(robot).template cast<S>();
  const long at_start = testing::g_allocations.load();
  WorkspaceTpl<S> ws(m);
  ASSERT_GT(testing::g_allocations.load(), at_start) << "the allocation counter is not hooked in";
  std::mt19937 rng(9);
  const VectorX<S> q = testing::random_vector(rng, m.nv, 1.0).template cast<S>(),
                   qd = testing::random_vector(rng, m.nv, 1.0).template cast<S>(),
                   u = testing::random_vector(rng, m.nv, 1.0).template cast<S>(),
                   fext = testing::random_vector(rng, 6 * m.nv, 1.0).template cast<S>();
  const MatrixX<S> minv = MatrixX<S>::Identity(m.nv, m.nv);
  const long before = testing::g_allocations.load();
  bool ok = true;
  ok &= rnea(m, ws, q, qd, u, fext.data()).is_ok();
  ok &= crba(m, ws, q).is_ok();
  ok &= minverse(m, ws, q).is_ok();
  ok &= forward_dynamics(m, ws, q, qd, u, fext.data()).is_ok();
  ok &= rnea_derivatives(m, ws, q, qd, u).is_ok();
  ok &= fd_derivatives(m, ws, q, qd, u, InputKind::kTau).is_ok();
  ok &= fd_derivatives(m, ws, q, qd, u, InputKind::kQdd, fext.data(), &minv).is_ok();
  ok &= fd_derivatives(m, ws, q, qd, u, InputKind::kTau, fext.data(), &minv).is_ok();
  // the specialized variants an execution plan selects, and evaluate_outputs under a plan
  ExecutionPlan plan;
  plan.dqdd_dqd = false;
  plan.gravity = false;
  plan.external_forces = ExternalForces::kSomeBodies;
  plan.fext_bodies.set(m.nv - 1);
  plan.minv_supplied = true;
  ok &= fd_derivatives(m, ws, q, qd, u, InputKind::kTau, plan, fext.data(), &minv).is_ok();
  ok &= evaluate_outputs(m, ws, q, qd, u, InputKind::kTau, kOutputDqddDq | kOutputMinv | kOutputDtauDqd, plan,
                         fext.data(), &minv)
            .is_ok();
  plan.dqdd_dq = false;
  plan.external_forces = ExternalForces::kAllBodies;
  plan.minv_supplied = false;
  ok &= fd_derivatives(m, ws, q, qd, u, InputKind::kQdd, plan, fext.data(), nullptr).is_ok();
  ok &= evaluate_outputs(m, ws, q, qd, u, InputKind::kTau, kOutputQdd | kOutputTau, plan, fext.data(), nullptr).is_ok();
  const long allocations = testing::g_allocations.load() - before;
  EXPECT_TRUE(ok) << robot;
  EXPECT_EQ(allocations, 0) << robot << " " << scalar_name<S>();
}

TEST(NoAllocation, EveryAlgorithmEveryRobotEveryScalar) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) {
    expect_no_allocation<double>(robot);
    expect_no_allocation<float>(robot);
    expect_no_allocation<Q16_16>(robot);
  }
}

}  // namespace
}  // namespace rbdgrad
