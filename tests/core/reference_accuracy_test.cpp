// Tests for core/src/algorithm/*.cpp against the Pinocchio 3.7.0 float64 reference
// (tests/data/reference/<robot>.jsonl, copied from the project's shared material).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "../support/error_statistics.hpp"
#include "../support/test_models.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/io/state_file.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {
namespace {

// the outputs compared, with the reference field that holds each
const char* const kOutputs[] = {"qdd", "M", "Minv", "dqdd_dq", "dqdd_dqd", "tau_id", "dtau_dq", "dtau_dqd"};
constexpr int kNumOutputs = 8;

struct ErrorStats {
  std::vector<double> per_output[kNumOutputs];
  int failures = 0;  // states whose computation returned an error
  std::string first_failure;

  double median(int k) const { return testing::median_of(per_output[k]); }
  double worst(int k) const { return testing::worst_of(per_output[k]); }
};

io::StateFile read_reference(const std::string& robot) {
  io::StateFile file;
  std::string error;
  const std::string path = std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl";
  if (!io::read_state_file(path, file, error)) throw std::runtime_error(error);
  return file;
}

Eigen::MatrixXd row_major(const std::vector<double>& flat, int rows, int cols) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(flat.data(), rows,
                                                                                                   cols);
}

// Runs fd_derivatives (tau input) and rnea_derivatives (at the reference qdd) in scalar S on every
// reference state and collects the relative Frobenius error of each output.
template <class S>
ErrorStats measure(const Model& model, const io::StateFile& file) {
  const ModelTpl<S> m = model.cast<S>();
  WorkspaceTpl<S> ws(m);
  const int n = m.nv;
  ErrorStats stats;
  for (const io::StateRecord& s : file.states) {
    auto vec = [&](const char* f) { return Eigen::Map<const Eigen::VectorXd>(s.at(f).data(), n).cast<S>().eval(); };
    const VectorX<S> q = vec("q"), qd = vec("qd"), tau = vec("tau"), qdd_ref = vec("qdd");
    Status st = fd_derivatives(m, ws, q, qd, tau, InputKind::kTau);
    const MatrixX<S> M = ws.M, Minv = ws.Minv, dq = ws.dqdd_dq, dqd = ws.dqdd_dqd;
    const VectorX<S> qdd = ws.qdd;
    if (st) st = rnea_derivatives(m, ws, q, qd, qdd_ref);
    if (!st) {
      if (stats.failures++ == 0) stats.first_failure = "state " + std::to_string(s.index) + ": " + st.to_string();
      continue;
    }
    const Eigen::MatrixXd results[kNumOutputs] = {
        qdd.template cast<double>(),     M.template cast<double>(),         Minv.template cast<double>(),
        dq.template cast<double>(),      dqd.template cast<double>(),       ws.tau.template cast<double>(),
        ws.dtau_dq.template cast<double>(), ws.dtau_dqd.template cast<double>()};
    for (int k = 0; k < kNumOutputs; ++k) {
      const std::vector<double>& ref = s.at(kOutputs[k]);
      const int rows = n, cols = static_cast<int>(ref.size()) / n;
      stats.per_output[k].push_back(testing::relative_error(results[k], row_major(ref, rows, cols)));
    }
  }
  return stats;
}

void print(const std::string& robot, const char* precision, const ErrorStats& e) {
  std::printf("%-14s %-5s", robot.c_str(), precision);
  for (int k = 0; k < kNumOutputs; ++k) std::printf(" %s %.1e/%.1e", kOutputs[k], e.median(k), e.worst(k));
  std::printf(" refused %d\n", e.failures);
}

class ReferenceAccuracy : public ::testing::TestWithParam<std::string> {};

TEST_P(ReferenceAccuracy, JointOrderMatchesPinocchio) {
  const Model model = testing::load_embedded(GetParam());
  const io::StateFile file = read_reference(GetParam());
  ASSERT_EQ(file.header.nv, model.nv);
  for (int i = 0; i < model.nv; ++i) EXPECT_EQ(model.joints[static_cast<size_t>(i)].name, file.header.joint_names[static_cast<size_t>(i)]);
  const std::vector<double>& parents = file.header.fields.at("joint_parent_index");
  for (int i = 0; i < model.nv; ++i) EXPECT_EQ(model.parent[static_cast<size_t>(i)], static_cast<int>(parents[static_cast<size_t>(i)]));
}

TEST_P(ReferenceAccuracy, DoubleWithin1e10) {
  const Model model = testing::load_embedded(GetParam());
  const ErrorStats e = measure<double>(model, read_reference(GetParam()));
  print(GetParam(), "f64", e);
  ASSERT_EQ(e.failures, 0) << e.first_failure;
  for (int k = 0; k < kNumOutputs; ++k) EXPECT_LE(e.worst(k), 1e-10) << kOutputs[k];
}

TEST_P(ReferenceAccuracy, FloatWithin1e4MedianAnd1e3Worst) {
  const Model model = testing::load_embedded(GetParam());
  const ErrorStats e = measure<float>(model, read_reference(GetParam()));
  print(GetParam(), "f32", e);
  ASSERT_EQ(e.failures, 0) << e.first_failure;
  for (int k = 0; k < kNumOutputs; ++k) {
    EXPECT_LE(e.median(k), 1e-4) << kOutputs[k];
    EXPECT_LE(e.worst(k), 1e-3) << kOutputs[k];
  }
}

// Q16.16 (resolution 1.5e-5, range +-32768) through the same world-frame algorithms. Measured on
// 2026-11-22 (worst relative error over all eight outputs / states refused with an overflow error):
//   iiwa14 4.5e-2 / 10 of 32, panda 8.7e-3 / 3, talos_reduced 2.6e-2 / 6, hyq 3.9e-3 / 0.
// The bounds below add 25% to the worst error; fixed-point arithmetic is integer-exact, so the
// figures only move when the algorithms change. A refused state is reported, never wrong silently.
struct FixedBound {
  const char* robot;
  double worst;
  int max_refused;
};
constexpr FixedBound kFixedBounds[] = {
    {"iiwa14", 0.054, 10}, {"panda", 0.011, 3}, {"talos_reduced", 0.033, 6}, {"hyq", 0.0049, 0}};

TEST_P(ReferenceAccuracy, FixedPointErrorWithinMeasuredBound) {
  const Model model = testing::load_embedded(GetParam());
  const ErrorStats e = measure<Q16_16>(model, read_reference(GetParam()));
  print(GetParam(), "fixed", e);
  const FixedBound* bound = nullptr;
  for (const FixedBound& b : kFixedBounds)
    if (GetParam() == b.robot) bound = &b;
  ASSERT_NE(bound, nullptr);
  EXPECT_LE(e.failures, bound->max_refused) << e.first_failure;
  if (e.failures > 0) {
    EXPECT_NE(e.first_failure.find("fixed-point overflow"), std::string::npos) << e.first_failure;
  }
  for (int k = 0; k < kNumOutputs; ++k) EXPECT_LE(e.worst(k), bound->worst) << kOutputs[k];
}

INSTANTIATE_TEST_SUITE_P(Robots, ReferenceAccuracy,
                         ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq"));

}  // namespace
}  // namespace rbdgrad
