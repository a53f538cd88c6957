// The real daemon through the client library: CPU f64 results equal the in-process core results
// bit for bit (unary, asynchronous and streaming, over TCP and the Unix socket), and the Pinocchio
// reference states pass through the server within the core library's tolerances.
#include <gtest/gtest.h>

#include <algorithm>

#include "integration_support.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::testing {
namespace {

constexpr std::uint32_t kAllOutputs = 255;

class ServiceResults : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { daemon_ = new DaemonProcess(RBDGRADD_PATH, daemon_config()); }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
  }
  static DaemonProcess* daemon_;
};
DaemonProcess* ServiceResults::daemon_ = nullptr;

TEST_F(ServiceResults, EveryRobotEqualsCoreBitForBitOverTcpAndUnixSocket) {
  for (const std::string& address : {daemon_->tcp_address(), daemon_->unix_address()}) {
    const Client client(address);
    for (const char* robot : kRobots) {
      SCOPED_TRACE(std::string(robot) + " via " + address);
      const Model model = load_embedded(robot);
      for (const ComputeInput input : {ComputeInput::kTau, ComputeInput::kQdd}) {
        const Batch b = random_batch(robot, model.nv, 9, 11);
        const ComputeResult r = client.compute(b.request(kAllOutputs, input));
        EXPECT_EQ(r.backend(), Backend::kCpu);
        EXPECT_EQ(r.precision(), Precision::kF64);
        EXPECT_EQ(r.num_states(), 9u);
        EXPECT_EQ(r.nv(), model.nv);
        EXPECT_TRUE(bitwise_equal(r, expected_outputs(model, b, kAllOutputs, input == ComputeInput::kTau)));
      }
    }
  }
}

TEST_F(ServiceResults, AsyncAndStreamingCallsEqualCore) {
  const Client client(daemon_->unix_address());
  const Model model = load_embedded("iiwa14");
  const std::uint32_t outputs = Output::kDqddDq | Output::kDqddDqd | Output::kQdd;
  const Batch a = random_batch("iiwa14", model.nv, 33, 1), b = random_batch("iiwa14", model.nv, 7, 2);
  const auto expected_a = expected_outputs(model, a, outputs, true);
  const auto expected_b = expected_outputs(model, b, outputs, true);

  std::future<ComputeResult> fa = client.compute_async(a.request(outputs));
  std::promise<std::pair<RpcStatus, ComputeResult>> pb;
  client.compute_async(b.request(outputs), [&](RpcStatus s, ComputeResult r) { pb.set_value({s, std::move(r)}); });
  EXPECT_TRUE(bitwise_equal(fa.get(), expected_a));
  auto [status_b, result_b] = pb.get_future().get();
  ASSERT_TRUE(status_b) << status_b.to_string();
  EXPECT_TRUE(bitwise_equal(result_b, expected_b));

  // a control loop: alternate the two batches on one stream; each response is the one asked for
  ComputeSession session = client.open_session();
  for (int step = 0; step < 20; ++step) {
    const bool even = step % 2 == 0;
    ComputeRequest req = (even ? a : b).request(outputs);
    req.request_id = "step-" + std::to_string(step);
    const ComputeResult& r = session.step(req);
    EXPECT_EQ(r.request_id(), req.request_id);
    EXPECT_TRUE(bitwise_equal(r, even ? expected_a : expected_b)) << "step " << step;
  }
  EXPECT_TRUE(session.close());
}

TEST_F(ServiceResults, ServerTimingsAreConsistent) {
  const Client client(daemon_->tcp_address());
  const Model model = load_embedded("talos_reduced");
  const ComputeResult r =
      client.compute(random_batch("talos_reduced", model.nv, 64, 3).request(Output::kDqddDq | Output::kDqddDqd));
  const ComputeTimings& t = r.timings();
  EXPECT_GT(t.compute_us, 0u);  // 64 talos gradients take hundreds of microseconds
  EXPECT_GE(t.total_us, t.queue_us + t.compute_us);
  EXPECT_GE(t.round_trip_us, static_cast<double>(t.total_us));
}

// The Pinocchio reference states through the server, against the reference values: relative
// Frobenius error per state, f64 worst <= 1e-10, f32 median <= 1e-4 and worst <= 1e-3 (the core
// library's bounds, tests/core/reference_accuracy_test.cpp).
struct Tolerance {
  Precision precision;
  ScalarType output_type;
  double median, worst;
};

void check_reference(const Client& client, const std::string& robot, const Tolerance& tol) {
  io::StateFile file;
  std::string error;
  ASSERT_TRUE(io::read_state_file(std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl", file, error))
      << error;
  const int nv = static_cast<int>(file.header.nv);
  std::vector<double> q, qd, tau, qdd;
  for (const io::StateRecord& s : file.states) {
    for (auto [field, dst] : {std::pair{"q", &q}, {"qd", &qd}, {"tau", &tau}, {"qdd", &qdd}})
      dst->insert(dst->end(), s.at(field).begin(), s.at(field).end());
  }
  ComputeRequest req;
  req.model = robot;
  req.num_states = static_cast<std::uint32_t>(file.states.size());
  req.precision = tol.precision;
  req.output_type = tol.output_type;
  req.q = q;
  req.qd = qd;
  // forward dynamics and its derivatives from tau; inverse dynamics and its derivatives at the
  // reference qdd
  req.input = ComputeInput::kTau;
  req.u = tau;
  req.outputs = Output::kQdd | Output::kM | Output::kMinv | Output::kDqddDq | Output::kDqddDqd;
  const ComputeResult fd = client.compute(req);
  req.input = ComputeInput::kQdd;
  req.u = qdd;
  req.outputs = Output::kTau | Output::kDtauDq | Output::kDtauDqd;
  const ComputeResult id = client.compute(req);

  const std::pair<Output, const char*> fields[] = {
      {Output::kQdd, "qdd"},         {Output::kM, "M"},         {Output::kMinv, "Minv"},
      {Output::kDqddDq, "dqdd_dq"},  {Output::kDqddDqd, "dqdd_dqd"}, {Output::kTau, "tau_id"},
      {Output::kDtauDq, "dtau_dq"},  {Output::kDtauDqd, "dtau_dqd"}};
  for (const auto& [output, field] : fields) {
    const ComputeResult& r = (output == Output::kTau || output == Output::kDtauDq || output == Output::kDtauDqd) ? id : fd;
    std::vector<double> errors;
    for (std::uint32_t k = 0; k < req.num_states; ++k) {
      const std::vector<double>& ref = file.states[k].at(field);
      const int cols = static_cast<int>(ref.size()) / nv;
      const Eigen::MatrixXd ref_m =
          Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(ref.data(), nv, cols);
      Eigen::MatrixXd got;
      if (tol.output_type == ScalarType::kF64) {
        got = cols == 1 ? Eigen::MatrixXd(r.vector(output, k)) : Eigen::MatrixXd(r.matrix(output, k));
      } else {
        got = cols == 1 ? Eigen::MatrixXd(r.vector_f32(output, k).cast<double>())
                        : Eigen::MatrixXd(r.matrix_f32(output, k).cast<double>());
      }
      errors.push_back(relative_error(got, ref_m));
    }
    std::sort(errors.begin(), errors.end());
    EXPECT_LE(errors[errors.size() / 2], tol.median) << robot << " " << field << " median";
    EXPECT_LE(errors.back(), tol.worst) << robot << " " << field << " worst";
  }
}

TEST_F(ServiceResults, ReferenceStatesF64Within1e10) {
  const Client client(daemon_->unix_address());
  for (const char* robot : kRobots) check_reference(client, robot, {Precision::kF64, ScalarType::kF64, 1e-10, 1e-10});
}

TEST_F(ServiceResults, ReferenceStatesF32WithinCoreBounds) {
  const Client client(daemon_->unix_address());
  for (const char* robot : kRobots) check_reference(client, robot, {Precision::kF32, ScalarType::kF32, 1e-4, 1e-3});
}

}  // namespace
}  // namespace rbdgrad::testing
