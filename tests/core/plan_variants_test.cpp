// Tests for the specialized instantiations an ExecutionPlan selects (core/src/algorithm/
// fd_derivatives.cpp, rnea_derivatives.cpp, rnea.cpp, forward_dynamics.cpp and evaluate.cpp under a
// plan): every scene variant gives the numbers of the full computation followed by selecting the
// outputs, on iiwa14, talos_reduced (also with its hands and head locked), hyq and a 100-joint tree.
// Gravity off is the model with zero gravity, forces on some bodies are fext with zeros elsewhere.
// Outputs a variant skips are poisoned and must stay so; forces it skips are NaN and must not be read.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <type_traits>
#include <string>
#include <vector>

#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/rnea.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {
namespace {

constexpr double kPoison = -7777.0;  // in the outputs a variant must not write

struct Robot {
  std::string label;
  Model model;
};

const std::vector<Robot>& robots() {
  static const std::vector<Robot> all = [] {
    std::vector<Robot> r;
    for (const char* name : {"iiwa14", "talos_reduced", "hyq"}) r.push_back({name, testing::load_embedded(name)});
    Model locked;
    const Model& talos = r[1].model;
    if (!lock_joints(talos, testing::talos_hands_and_head(talos), locked)) throw std::runtime_error("lock_joints failed");
    r.push_back({"talos_reduced, hands and head locked", locked});
    // more bodies than one 64-bit word of the force mask
    r.push_back({"random tree of 100 joints", testing::random_model(5, 100, testing::TreeShape::kBranching)});
    return r;
  }();
  return all;
}

template <class S>
double to_double(S x) {
  if constexpr (is_fixed_point_v<S>) return x.to_double();
  else return static_cast<double>(x);
}

// Element-wise equality (== : bit for bit up to the sign of zero), naming the first difference.
template <class A, class B>
::testing::AssertionResult same_values(const A& got, const B& want) {
  if (got.rows() != want.rows() || got.cols() != want.cols()) return ::testing::AssertionFailure() << "sizes differ";
  for (Eigen::Index j = 0; j < got.cols(); ++j)
    for (Eigen::Index i = 0; i < got.rows(); ++i)
      if (!(got(i, j) == want(i, j)))
        return ::testing::AssertionFailure() << "(" << i << ", " << j << "): " << to_double(got(i, j)) << " instead of "
                                             << to_double(want(i, j));
  return ::testing::AssertionSuccess();
}

template <class A>
::testing::AssertionResult untouched(const A& m) {
  using S = typename A::Scalar;
  for (Eigen::Index j = 0; j < m.cols(); ++j)
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      if (!(m(i, j) == S(kPoison)))
        return ::testing::AssertionFailure() << "written at (" << i << ", " << j << "): " << to_double(m(i, j));
  return ::testing::AssertionSuccess();
}

// The relative difference a variant may have from the full computation when it is another
// instantiation: GCC contracts a * b + c into fused multiply-adds (-ffp-contract=fast, its C++
// default) as each instantiation's code allows, so the same expression may round differently in two
// of them (compiled with -ffp-contract=off, every variant matches bit for bit). Q16.16 is integer
// arithmetic: always bit for bit.
template <class S>
double tolerance() {
  if constexpr (is_fixed_point_v<S>) return 0;
  else return std::is_same_v<S, float> ? 1e-5 : 1e-12;
}

// Bit for bit when `exact` (the same instantiation as the reference, or fixed point), else
// within tolerance<S>() in the relative Frobenius norm.
template <class A, class B>
::testing::AssertionResult equal_or_close(const A& got, const B& want, bool exact) {
  using S = typename A::Scalar;
  if (exact || tolerance<S>() == 0) return same_values(got, want);
  const Eigen::MatrixXd g = got.unaryExpr([](S x) { return to_double(x); });
  const Eigen::MatrixXd w = want.unaryExpr([](S x) { return to_double(x); });
  const double error = testing::relative_error(g, w);
  if (error <= tolerance<S>()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "relative error " << error;
}

// Poisons the outputs a call must not write, those it writes whole, and the per-body scratch (so
// that a stage that was skipped but is needed cannot live on a previous call's values); the d tau
// columns it computes (dq, dqd) and M are zeroed as in a new workspace instead: the algorithms
// write only the entries the tree does not make zero.
template <class S>
void poison(WorkspaceTpl<S>& ws, bool dq, bool dqd) {
  const S p(kPoison);
  for (MatrixX<S>* m : {&ws.dqdd_dq, &ws.dqdd_dqd, &ws.Minv}) m->setConstant(p);
  for (VectorX<S>* v : {&ws.qdd, &ws.tau, &ws.aba_d, &ws.aba_u}) v->setConstant(p);
  for (auto* per_body : {&ws.axis, &ws.v, &ws.a, &ws.a_qdd, &ws.h, &ws.f_qdd, &ws.f, &ws.alpha, &ws.beta, &ws.u,
                         &ws.w, &ws.aba_axis, &ws.aba_c, &ws.pA, &ws.U, &ws.aba_a})
    for (Vec6<S>& x : *per_body) x.setConstant(p);
  for (auto* per_body : {&ws.I, &ws.I_joint, &ws.Ic, &ws.Bc, &ws.IA})
    for (Mat6<S>& x : *per_body) x.setConstant(p);
  ws.M.setZero();
  if (dq) ws.dtau_dq.setZero();
  else ws.dtau_dq.setConstant(p);
  if (dqd) ws.dtau_dqd.setZero();
  else ws.dtau_dqd.setConstant(p);
}

// A force value no computation may read: NaN, or in fixed point a value whose moments overflow.
template <class S>
S unread_force() {
  if constexpr (is_fixed_point_v<S>) return S(20000.0);
  else return std::numeric_limits<S>::quiet_NaN();
}

// One state and the force arrays the variants read.
template <class S>
struct Case {
  VectorX<S> q, qd, tau, qdd;
  VectorX<S> fext;         // (6 nv) a force on every body
  VectorX<S> fext_masked;  // fext on the mask's bodies, unread_force elsewhere
  VectorX<S> fext_zeroed;  // fext on the mask's bodies, zero elsewhere: the reference
  VectorX<S> fext_unread;  // unread_force everywhere: what a plan without forces is given
  MatrixX<S> minv;         // M^-1 at a nearby q, as cached by the caller: not M^-1(q)
  MatrixX<S> minv_at_q;    // M^-1(q)
  BodyMask mask;           // three bodies, the first, one in the middle and the last
};

template <class S>
Case<S> make_case(const Model& md, unsigned seed) {
  std::mt19937 rng(seed);
  const int nv = md.nv;
  auto vec = [&](int n, double scale) { return VectorX<S>(testing::random_vector(rng, n, scale).cast<S>()); };
  Case<S> c;
  c.q = vec(nv, 1.0);
  c.qd = vec(nv, 1.0);
  c.tau = vec(nv, 2.0);
  c.qdd = vec(nv, 1.0);
  c.fext = vec(6 * nv, 1.0);
  for (int b : {0, nv / 3, nv - 1}) c.mask.set(b);
  c.fext_masked = VectorX<S>::Constant(6 * nv, unread_force<S>());
  c.fext_zeroed = VectorX<S>::Zero(6 * nv);
  c.mask.for_each(nv, [&](int b) {
    c.fext_masked.template segment<6>(6 * b) = c.fext.template segment<6>(6 * b);
    c.fext_zeroed.template segment<6>(6 * b) = c.fext.template segment<6>(6 * b);
  });
  c.fext_unread = VectorX<S>::Constant(6 * nv, unread_force<S>());
  Workspace ws(md);
  const Eigen::VectorXd q_near = c.q.template cast<double>() + testing::random_vector(rng, nv, 0.05);
  if (!minverse(md, ws, q_near)) throw std::runtime_error("minverse failed");
  c.minv = ws.Minv.cast<S>();
  if (!minverse(md, ws, c.q.template cast<double>().eval())) throw std::runtime_error("minverse failed");
  c.minv_at_q = ws.Minv.cast<S>();
  return c;
}

std::vector<ExecutionPlan> every_plan(const BodyMask& mask) {
  std::vector<ExecutionPlan> plans;
  for (bool dq : {false, true})
    for (bool dqd : {false, true})
      for (bool gravity : {false, true})
        for (ExternalForces forces : {ExternalForces::kNone, ExternalForces::kAllBodies, ExternalForces::kSomeBodies})
          for (bool minv : {false, true}) {
            ExecutionPlan p;
            p.dqdd_dq = dq;
            p.dqdd_dqd = dqd;
            p.gravity = gravity;
            p.external_forces = forces;
            if (forces == ExternalForces::kSomeBodies) p.fext_bodies = mask;
            p.minv_supplied = minv;
            plans.push_back(p);
          }
  return plans;
}

std::string describe(const ExecutionPlan& p, InputKind kind) {
  const char* forces[] = {"no forces", "forces on all bodies", "forces on some bodies"};
  return std::string(p.dqdd_dq ? "dq " : "") + (p.dqdd_dqd ? "dqd " : "") + (p.gravity ? "gravity, " : "no gravity, ") +
         forces[static_cast<int>(p.external_forces)] + (p.minv_supplied ? ", M^-1 supplied" : ", M^-1 computed") +
         (kind == InputKind::kTau ? ", tau input" : ", qdd input");
}

// The fext a plan's variant is given, and the one its reference (the full computation) is given.
template <class S>
const S* variant_forces(const Case<S>& c, const ExecutionPlan& p) {
  switch (p.external_forces) {
    case ExternalForces::kNone: return c.fext_unread.data();
    case ExternalForces::kAllBodies: return c.fext.data();
    case ExternalForces::kSomeBodies: return c.fext_masked.data();
  }
  return nullptr;
}
template <class S>
const S* reference_forces(const Case<S>& c, const ExecutionPlan& p) {
  switch (p.external_forces) {
    case ExternalForces::kNone: return nullptr;
    case ExternalForces::kAllBodies: return c.fext.data();
    case ExternalForces::kSomeBodies: return c.fext_zeroed.data();
  }
  return nullptr;
}

// fd_derivatives under every plan against the full computation (every stage, on the model with
// zero gravity when the plan has none) followed by selecting the outputs: bit for bit, since each
// kept stage does the same arithmetic.
template <class S>
void expect_fd_variants(const Model& md, const std::string& label, unsigned seed) {
  const ModelTpl<S> model = md.template cast<S>();
  ModelTpl<S> zero_gravity = model;
  zero_gravity.gravity.setZero();
  WorkspaceTpl<S> ws(model), ref(model);
  const Case<S> c = make_case<S>(md, seed);
  int compared = 0;
  for (InputKind kind : {InputKind::kTau, InputKind::kQdd}) {
    const VectorX<S>& u = kind == InputKind::kTau ? c.tau : c.qdd;
    for (const ExecutionPlan& p : every_plan(c.mask)) {
      const std::string what = label + " " + scalar_name<S>() + ": " + describe(p, kind);
      const MatrixX<S>* minv = p.minv_supplied ? &c.minv : nullptr;
      const Status rs = fd_derivatives(p.gravity ? model : zero_gravity, ref, c.q, c.qd, u, kind,
                                       reference_forces(c, p), minv);
      poison(ws, p.dqdd_dq, p.dqdd_dqd);
      const Status vs = fd_derivatives(model, ws, c.q, c.qd, u, kind, p, variant_forces(c, p), minv);
      if (!rs) {
        // a fixed-point overflow (the variant, a subset of the arithmetic, may not meet it)
        EXPECT_TRUE(is_fixed_point_v<S>) << what << ": " << rs.message();
        continue;
      }
      ASSERT_TRUE(vs) << what << ": " << vs.message();
      ++compared;
      // the reference's own instantiation when the plan keeps both columns: gravity, the forces'
      // bodies and M^-1 are chosen per call
      const bool exact = p.dqdd_dq && p.dqdd_dqd;
      EXPECT_TRUE(equal_or_close(ws.qdd, ref.qdd, exact)) << what << ": qdd";
      EXPECT_TRUE(p.dqdd_dq ? equal_or_close(ws.dqdd_dq, ref.dqdd_dq, exact) : untouched(ws.dqdd_dq))
          << what << ": dqdd_dq";
      EXPECT_TRUE(p.dqdd_dqd ? equal_or_close(ws.dqdd_dqd, ref.dqdd_dqd, exact) : untouched(ws.dqdd_dqd))
          << what << ": dqdd_dqd";
      // a skipped column's scratch is not written either
      if (!p.dqdd_dq) {
        EXPECT_TRUE(untouched(ws.dtau_dq)) << what << ": dtau_dq";
      }
      if (!p.dqdd_dqd) {
        EXPECT_TRUE(untouched(ws.dtau_dqd)) << what << ": dtau_dqd";
      }
      EXPECT_TRUE(p.minv_supplied ? untouched(ws.Minv) : equal_or_close(ws.Minv, ref.Minv, exact)) << what << ": Minv";
      EXPECT_TRUE(equal_or_close(ws.M, ref.M, exact)) << what << ": M";
    }
  }
  EXPECT_GT(compared, 0) << label << " " << scalar_name<S>() << ": every state refused";
}

TEST(PlanVariants, GradientEqualsTheFullComputationSelectedF64) {
  unsigned seed = 100;
  for (const Robot& r : robots()) {
    expect_fd_variants<double>(r.model, r.label, seed++);
    expect_fd_variants<double>(r.model, r.label, seed++);
  }
}

TEST(PlanVariants, GradientEqualsTheFullComputationSelectedF32AndFixedPoint) {
  unsigned seed = 200;
  for (const Robot& r : robots()) {
    expect_fd_variants<float>(r.model, r.label, seed++);
    // Q16.16 on the arm and the quadruped: talos's distal links leave the format at random states
    if (r.label == "iiwa14" || r.label == "hyq") expect_fd_variants<Q16_16>(r.model, r.label, seed++);
  }
}

TEST(PlanVariants, TheSkippedTermsChangeTheResult) {
  // so that a variant that dropped gravity or a force the plan keeps would fail the tests above
  for (const Robot& r : robots()) {
    const Case<double> c = make_case<double>(r.model, 7);
    Model zero_gravity = r.model;
    zero_gravity.gravity.setZero();
    Workspace a(r.model), b(r.model);
    ASSERT_TRUE(fd_derivatives(r.model, a, c.q, c.qd, c.tau, InputKind::kTau));
    ASSERT_TRUE(fd_derivatives(zero_gravity, b, c.q, c.qd, c.tau, InputKind::kTau));
    EXPECT_GT((a.dqdd_dq - b.dqdd_dq).norm(), 1e-6 * a.dqdd_dq.norm()) << r.label << ": gravity";
    ASSERT_TRUE(fd_derivatives(r.model, b, c.q, c.qd, c.tau, InputKind::kTau, c.fext_zeroed.data()));
    EXPECT_GT((a.dqdd_dq - b.dqdd_dq).norm(), 1e-6 * a.dqdd_dq.norm()) << r.label << ": forces on the mask's bodies";
    ASSERT_TRUE(fd_derivatives(r.model, b, c.q, c.qd, c.tau, InputKind::kTau, nullptr, &c.minv));
    EXPECT_GT((a.dqdd_dqd - b.dqdd_dqd).norm(), 1e-6 * a.dqdd_dqd.norm()) << r.label << ": a cached M^-1";
    // a force on a body outside the mask would be read as NaN
    ExecutionPlan p;
    p.external_forces = ExternalForces::kAllBodies;
    const Status s = fd_derivatives(r.model, b, c.q, c.qd, c.tau, InputKind::kTau, p, c.fext_masked.data(), nullptr);
    EXPECT_EQ(s.code(), StatusCode::kOutOfRange) << r.label << ": " << s.message();
  }
}

// evaluate_outputs with a subset of the outputs under a plan against evaluate_outputs with every
// output (the full computation), selected. Within 1e-12: qdd alone comes from the articulated-body
// pass, qdd with the gradient from M^-1 (tau - c), and tau's derivatives are taken at that qdd. The
// supplied M^-1 is M^-1(q) here, so that both ways to qdd agree.
TEST(PlanVariants, EvaluateOutputsEqualsEveryOutputSelected) {
  const std::uint32_t subsets[] = {
      kOutputQdd,
      kOutputMinv,
      kOutputDqddDq,
      kOutputDqddDqd,
      kOutputDqddDq | kOutputMinv,
      kOutputTau,
      kOutputDtauDq,
      kOutputDtauDqd,
      kOutputM,
      kOutputQdd | kOutputDtauDqd | kOutputM,
  };
  for (const Robot& r : robots()) {
    Model zero_gravity = r.model;
    zero_gravity.gravity.setZero();
    Workspace ws(r.model), ref(r.model);
    const Case<double> c = make_case<double>(r.model, 11);
    for (InputKind kind : {InputKind::kTau, InputKind::kQdd}) {
      const Eigen::VectorXd& u = kind == InputKind::kTau ? c.tau : c.qdd;
      for (const ExecutionPlan& full_plan : every_plan(c.mask)) {
        if (!full_plan.dqdd_dq || !full_plan.dqdd_dqd) continue;  // the outputs choose the columns
        const MatrixX<double>* minv = full_plan.minv_supplied ? &c.minv_at_q : nullptr;
        ASSERT_TRUE(evaluate_outputs(full_plan.gravity ? r.model : zero_gravity, ref, c.q, c.qd, u, kind, kAllOutputs,
                                     reference_forces(c, full_plan), minv));
        for (std::uint32_t outputs : subsets) {
          const std::string what = r.label + ": outputs " + std::to_string(outputs) + ", " + describe(full_plan, kind);
          auto want = [&](std::uint32_t f) { return (outputs & f) != 0; };
          poison(ws, want(kOutputDqddDq | kOutputDtauDq), want(kOutputDqddDqd | kOutputDtauDqd));
          ASSERT_TRUE(evaluate_outputs(r.model, ws, c.q, c.qd, u, kind, outputs, full_plan,
                                       variant_forces(c, full_plan), minv))
              << what;
          const std::pair<std::uint32_t, std::pair<const Eigen::MatrixXd*, const Eigen::MatrixXd*>> matrices[] = {
              {kOutputMinv, {&ws.Minv, &ref.Minv}},       {kOutputDqddDq, {&ws.dqdd_dq, &ref.dqdd_dq}},
              {kOutputDqddDqd, {&ws.dqdd_dqd, &ref.dqdd_dqd}}, {kOutputDtauDq, {&ws.dtau_dq, &ref.dtau_dq}},
              {kOutputDtauDqd, {&ws.dtau_dqd, &ref.dtau_dqd}}, {kOutputM, {&ws.M, &ref.M}}};
          const double worst = 1e-12;
          for (const auto& [flag, m] : matrices) {
            if (want(flag)) {
              EXPECT_LT(testing::relative_error(*m.first, *m.second), worst) << what << " flag " << flag;
            }
          }
          if (want(kOutputQdd)) {
            EXPECT_LT(testing::relative_error(ws.qdd, ref.qdd), worst) << what;
          }
          if (want(kOutputTau)) {
            EXPECT_LT(testing::relative_error(ws.tau, ref.tau), worst) << what;
          }
          // a d qdd column not asked for is never written, nor a d tau column nothing needs
          EXPECT_TRUE(want(kOutputDqddDq) || untouched(ws.dqdd_dq)) << what;
          EXPECT_TRUE(want(kOutputDqddDqd) || untouched(ws.dqdd_dqd)) << what;
          EXPECT_TRUE(want(kOutputDqddDq | kOutputDtauDq) || untouched(ws.dtau_dq)) << what;
          EXPECT_TRUE(want(kOutputDqddDqd | kOutputDtauDqd) || untouched(ws.dtau_dqd)) << what;
        }
      }
    }
  }
}

TEST(PlanVariants, RneaAndForwardDynamicsTakeThePlansGravityAndForces) {
  for (const Robot& r : robots()) {
    Model zero_gravity = r.model;
    zero_gravity.gravity.setZero();
    Workspace ws(r.model), ref(r.model);
    const Case<double> c = make_case<double>(r.model, 13);
    for (const ExecutionPlan& p : every_plan(c.mask)) {
      if (p.dqdd_dq || p.dqdd_dqd || p.minv_supplied) continue;  // neither algorithm has these stages
      const std::string what = r.label + ": " + describe(p, InputKind::kTau);
      const Model& m = p.gravity ? r.model : zero_gravity;
      ASSERT_TRUE(rnea(m, ref, c.q, c.qd, c.qdd, reference_forces(c, p)));
      ASSERT_TRUE(rnea(r.model, ws, c.q, c.qd, c.qdd, p, variant_forces(c, p))) << what;
      EXPECT_TRUE(same_values(ws.tau, ref.tau)) << what;
      ASSERT_TRUE(forward_dynamics(m, ref, c.q, c.qd, c.tau, reference_forces(c, p)));
      ASSERT_TRUE(forward_dynamics(r.model, ws, c.q, c.qd, c.tau, p, variant_forces(c, p))) << what;
      EXPECT_TRUE(same_values(ws.qdd, ref.qdd)) << what;
    }
  }
}

// A scene with locked joints is the full model with those joints held (at their values, at rest)
// followed by selecting the kept joints' rows and columns: d tau/d(q, qd) restricted, and
// d qdd/d q = -M_kk^-1 (d tau/d q)_kk at the reduced model's qdd.
TEST(PlanVariants, LockedJointsAreTheFullComputationSelected) {
  const Model& talos = robots()[1].model;
  const std::vector<LockedJoint> locked = testing::talos_hands_and_head(talos);
  ASSERT_EQ(locked.size(), 10u);  // head 1-2, and per arm the wrist (5-7) and the gripper
  Model reduced;
  std::vector<int> kept;
  ASSERT_TRUE(lock_joints(talos, locked, reduced, &kept));
  ASSERT_EQ(reduced.nv, talos.nv - 10);
  const auto n = static_cast<int>(kept.size());
  auto at = [&](int k) { return kept[static_cast<std::size_t>(k)]; };
  Eigen::VectorXd held = Eigen::VectorXd::Zero(talos.nv);
  for (const LockedJoint& l : locked)
    for (int i = 0; i < talos.nv; ++i)
      if (talos.joints[static_cast<std::size_t>(i)].name == l.name) held(i) = l.value;
  std::mt19937 rng(17);
  for (bool gravity : {true, false}) {
    Model full = talos, red = reduced;
    if (!gravity) full.gravity.setZero();
    Workspace wf(full), wr(red);
    const Eigen::VectorXd q = testing::random_vector(rng, n, 1.0), qd = testing::random_vector(rng, n, 1.0),
                          tau = testing::random_vector(rng, n, 5.0);
    // the scene: the reduced model under a plan with gravity as asked (the reduced model keeps the full one's)
    ExecutionPlan p;
    p.gravity = gravity;
    ASSERT_TRUE(fd_derivatives(red, wr, q, qd, tau, InputKind::kTau, p, nullptr, nullptr));
    // the full model at the held state, then the kept rows and columns
    Eigen::VectorXd qf = held, qdf = Eigen::VectorXd::Zero(talos.nv), qddf = Eigen::VectorXd::Zero(talos.nv);
    for (int k = 0; k < n; ++k) {
      qf(at(k)) = q(k);
      qdf(at(k)) = qd(k);
      qddf(at(k)) = wr.qdd(k);
    }
    ASSERT_TRUE(rnea_derivatives(full, wf, qf, qdf, qddf));
    Eigen::MatrixXd M(n, n), dq(n, n), dqd(n, n);
    Eigen::VectorXd tau_full(n);
    for (int a = 0; a < n; ++a) {
      tau_full(a) = wf.tau(at(a));
      for (int b = 0; b < n; ++b) {
        M(a, b) = wf.M(at(a), at(b));
        dq(a, b) = wf.dtau_dq(at(a), at(b));
        dqd(a, b) = wf.dtau_dqd(at(a), at(b));
      }
    }
    const std::string what = gravity ? "gravity" : "no gravity";
    EXPECT_LT(testing::relative_error(tau_full, tau), 1e-12) << what;  // the reduced qdd solves the held dynamics
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    EXPECT_LT(testing::relative_error(wr.dqdd_dq, -llt.solve(dq)), 1e-12) << what;
    EXPECT_LT(testing::relative_error(wr.dqdd_dqd, -llt.solve(dqd)), 1e-12) << what;
    // and the inverse dynamics' derivatives directly, through evaluate_outputs
    ASSERT_TRUE(evaluate_outputs(red, wr, q, qd, wr.qdd, InputKind::kQdd, kOutputDtauDq | kOutputDtauDqd, p, nullptr,
                                 nullptr));
    EXPECT_LT(testing::relative_error(wr.dtau_dq, dq), 1e-12) << what;
    EXPECT_LT(testing::relative_error(wr.dtau_dqd, dqd), 1e-12) << what;
  }
}

}  // namespace
}  // namespace rbdgrad
