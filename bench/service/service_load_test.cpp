// Tests for the parts of service_load: response checks (a wrong answer must fail the benchmark),
// echo payload sizing (the echo must move the Dynamics call's bytes), percentiles, and the
// in-process computation against the core library through the real CPU plugin.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "in_process_compute.hpp"
#include "latency_stats.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"
#include "response_check.hpp"
#include "workload.hpp"

namespace rbdgrad::bench {
namespace {

Model iiwa14() {
  Model m;
  EXPECT_TRUE(load_urdf_string(std::string(embedded_robot_urdf("iiwa14")), "iiwa14", m).is_ok());
  return m;
}

// a response of the right shape for `req`: every requested output, f64 values 0.5
v1::ComputeResponse well_formed(const v1::ComputeRequest& req, int nv) {
  v1::ComputeResponse r;
  r.set_num_states(req.num_states());
  const std::vector<double> values(static_cast<std::size_t>(req.num_states()) * nv * nv, 0.5);
  for (v1::Tensor* t : {r.mutable_dqdd_dq(), r.mutable_dqdd_dqd()}) {
    t->set_type(v1::SCALAR_TYPE_F64);
    t->set_data(values.data(), values.size() * sizeof(double));
  }
  return r;
}

void put(v1::Tensor& t, std::size_t i, double v) { std::memcpy(t.mutable_data()->data() + i * sizeof(double), &v, sizeof v); }

class ResponseCheckTest : public ::testing::Test {
 protected:
  Model model = iiwa14();
  LoadOptions options;
  StatePool pool = make_state_pool(model, 4, v1::INPUT_KIND_TAU, 1);
  v1::ComputeRequest req = make_compute_request(pool, 4, options);
};

TEST_F(ResponseCheckTest, AcceptsAWellFormedResponse) {
  const v1::ComputeResponse r = well_formed(req, 7);
  EXPECT_TRUE(check_compute_response(req, 7, r, nullptr, 1e-9).is_ok());
  EXPECT_TRUE(check_compute_response(req, 7, r, &r, 0).is_ok());
}

TEST_F(ResponseCheckTest, RejectsWrongCountMissingOrShortOutputsAndExtras) {
  v1::ComputeResponse r = well_formed(req, 7);
  r.set_num_states(3);
  EXPECT_NE(check_compute_response(req, 7, r, nullptr, 1e-9).message().find("num_states is 3"), std::string::npos);

  r = well_formed(req, 7);
  r.mutable_dqdd_dqd()->clear_data();
  EXPECT_NE(check_compute_response(req, 7, r, nullptr, 1e-9).message().find("'dqdd_dqd' has 0 bytes"), std::string::npos);

  r = well_formed(req, 7);
  r.mutable_dqdd_dq()->mutable_data()->resize(8 * 10);
  EXPECT_FALSE(check_compute_response(req, 7, r, nullptr, 1e-9).is_ok());

  r = well_formed(req, 7);
  r.mutable_dqdd_dq()->set_type(v1::SCALAR_TYPE_F32);
  EXPECT_NE(check_compute_response(req, 7, r, nullptr, 1e-9).message().find("SCALAR_TYPE_F32"), std::string::npos);

  r = well_formed(req, 7);
  r.mutable_qdd()->set_type(v1::SCALAR_TYPE_F64);
  r.mutable_qdd()->set_data(std::string(4 * 7 * 8, '\0'));
  EXPECT_NE(check_compute_response(req, 7, r, nullptr, 1e-9).message().find("'qdd' is present but was not requested"),
            std::string::npos);
}

TEST_F(ResponseCheckTest, RejectsNonFiniteAndWrongValuesNamingStateAndElement) {
  v1::ComputeResponse r = well_formed(req, 7);
  put(*r.mutable_dqdd_dq(), 2 * 49 + 5, std::numeric_limits<double>::quiet_NaN());
  EXPECT_NE(check_compute_response(req, 7, r, nullptr, 1e-9).message().find("'dqdd_dq' state 2 element 5 is not finite"),
            std::string::npos);

  const v1::ComputeResponse reference = well_formed(req, 7);
  r = well_formed(req, 7);
  put(*r.mutable_dqdd_dqd(), 3 * 49 + 48, 0.5 + 1e-6);
  const Status s = check_compute_response(req, 7, r, &reference, 1e-9);
  EXPECT_NE(s.message().find("'dqdd_dqd' state 3 element 48"), std::string::npos) << s.message();
  EXPECT_TRUE(check_compute_response(req, 7, r, &reference, 1e-5).is_ok());

  // relative to the state's block: a near-zero element of a matrix with large entries may differ
  // by the matrix's rounding, an element of a block of small entries may not
  v1::ComputeResponse large = well_formed(req, 7);
  put(*large.mutable_dqdd_dq(), 1 * 49 + 7, 2000.0);
  r = large;
  put(*r.mutable_dqdd_dq(), 1 * 49 + 3, 0.5 + 1e-9);  // 5e-13 of the block's 2000
  EXPECT_TRUE(check_compute_response(req, 7, r, &large, 1e-9).is_ok());
  put(*r.mutable_dqdd_dq(), 2 * 49 + 3, 0.5 + 1e-6);  // state 2 has no large entry
  EXPECT_NE(check_compute_response(req, 7, r, &large, 1e-9).message().find("'dqdd_dq' state 2 element 3"),
            std::string::npos);
}

TEST(EchoSizing, EchoMovesTheDynamicsCallsBytes) {
  for (std::size_t in : {3u, 130u, 206u, 16384u, 10796u, 172083u})
    for (std::size_t out : {2u, 129u, 130u, 816u, 50212u, 802853u}) {
      const EchoRequest req = make_echo_request(in, out);
      EchoResponse resp;
      resp.mutable_payload()->resize(req.response_bytes());
      EXPECT_LE(std::abs(static_cast<long>(req.ByteSizeLong()) - static_cast<long>(in)), 1) << in;
      EXPECT_LE(std::abs(static_cast<long>(resp.ByteSizeLong()) - static_cast<long>(out)), 1) << out;
      EXPECT_TRUE(check_echo_response(req, resp).is_ok());
      resp.mutable_payload()->push_back('x');
      EXPECT_FALSE(check_echo_response(req, resp).is_ok());
    }
}

TEST(LatencyStats, NearestRankPercentiles) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);  // unsorted on purpose
  const LatencySummary s = summarize(v);
  EXPECT_EQ(s.count, 100u);
  EXPECT_EQ(s.p50_us, 50);
  EXPECT_EQ(s.p99_us, 99);
  EXPECT_EQ(s.mean_us, 50.5);
  EXPECT_EQ(s.max_us, 100);
  std::vector<double> one{7};
  EXPECT_EQ(summarize(one).p99_us, 7);
  std::vector<double> none;
  EXPECT_EQ(summarize(none).count, 0u);
}

TEST(InProcess, EqualsTheCoreLibraryAndSizesMatchTheEstimate) {
  const Model model = iiwa14();
  std::unique_ptr<InProcessCompute> compute;
  ASSERT_TRUE(InProcessCompute::create(RBDGRAD_CPU_PLUGIN_PATH, model, 2, compute).is_ok());
  LoadOptions options;
  const StatePool pool = make_state_pool(model, 16, v1::INPUT_KIND_TAU, 3);
  const v1::ComputeRequest req = make_compute_request(pool, 16, options);
  v1::ComputeResponse resp;
  StageTimes times;
  ASSERT_TRUE(compute->run(req, RBDGRAD_PRECISION_F64, resp, &times).is_ok());
  ASSERT_TRUE(check_compute_response(req, 7, resp, nullptr, 0).is_ok());
  EXPECT_GT(times.compute_us, 0);
  // only the timings' varints are estimated
  EXPECT_LE(std::abs(static_cast<long>(expected_response_bytes(req, 7)) - static_cast<long>(resp.ByteSizeLong())), 16);

  // state 9 against fd_derivatives of the core library, row-major on the wire
  Workspace ws(model);
  const Eigen::Map<const Eigen::VectorXd> q(&pool.q[9 * 7], 7), qd(&pool.qd[9 * 7], 7), tau(&pool.u[9 * 7], 7);
  ASSERT_TRUE(fd_derivatives(model, ws, q, qd, tau, InputKind::kTau).is_ok());
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) {
      double wire;
      std::memcpy(&wire, resp.dqdd_dq().data().data() + ((9 * 7 + i) * 7 + j) * sizeof(double), sizeof wire);
      EXPECT_EQ(wire, ws.dqdd_dq(i, j)) << i << "," << j;
    }
}

}  // namespace
}  // namespace rbdgrad::bench
