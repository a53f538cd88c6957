// Tests for client/src/request_encoding.cpp: what the server receives for a ComputeRequest.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"
#include "test_batch.hpp"

namespace rbdgrad::testing {
namespace {

std::vector<double> doubles_of(const v1::Tensor& t) {
  std::vector<double> v(t.data().size() / sizeof(double));
  std::memcpy(v.data(), t.data().data(), v.size() * sizeof(double));
  return v;
}

TEST(ClientRequestEncoding, EveryFieldReachesTheServer) {
  FakeServer server;
  Client client(server.address());
  const TestBatch batch(3, 4);
  std::vector<double> minv(3 * 4 * 4), fext(3 * 4 * 6);
  for (std::size_t i = 0; i < minv.size(); ++i) minv[i] = 0.5 + static_cast<double>(i);
  for (std::size_t i = 0; i < fext.size(); ++i) fext[i] = -1.0 * static_cast<double>(i);

  ComputeRequest req = batch.request("panda");
  req.precision = Precision::kF32;
  req.input = ComputeInput::kQdd;
  // listed out of bit order: travels in bit order, each once
  req.outputs = Output::kM | Output::kQdd | Output::kDqddDq;
  req.minv = minv;
  req.fext = fext;
  req.backend = Backend::kCuda;
  req.output_type = ScalarType::kF32;
  req.request_id = "enc-1";
  (void)client.compute(req);

  const std::vector<v1::ComputeRequest> got = server.service().received();
  ASSERT_EQ(got.size(), 1u);
  const v1::ComputeRequest& m = got[0];
  EXPECT_EQ(m.model(), "panda");
  EXPECT_EQ(m.num_states(), 3u);
  EXPECT_EQ(m.precision(), v1::PRECISION_F32);
  EXPECT_EQ(m.input_kind(), v1::INPUT_KIND_QDD);
  ASSERT_EQ(m.outputs_size(), 3);
  EXPECT_EQ(m.outputs(0), v1::OUTPUT_QDD);
  EXPECT_EQ(m.outputs(1), v1::OUTPUT_DQDD_DQ);
  EXPECT_EQ(m.outputs(2), v1::OUTPUT_M);
  // inputs: one little-endian f64 block per field, bit-exact
  for (const v1::Tensor* t : {&m.q(), &m.qd(), &m.u(), &m.minv(), &m.fext()}) EXPECT_EQ(t->type(), v1::SCALAR_TYPE_F64);
  EXPECT_EQ(doubles_of(m.q()), batch.q);
  EXPECT_EQ(doubles_of(m.qd()), batch.qd);
  EXPECT_EQ(doubles_of(m.u()), batch.u);
  EXPECT_EQ(doubles_of(m.minv()), minv);
  EXPECT_EQ(doubles_of(m.fext()), fext);
  EXPECT_EQ(m.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(m.output_type(), v1::SCALAR_TYPE_F32);
  EXPECT_EQ(m.request_id(), "enc-1");
}

TEST(ClientRequestEncoding, DefaultsAndAbsentOptionalInputs) {
  FakeServer server;
  Client client(server.address());
  const TestBatch batch(2, 3);
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kTau);
  (void)client.compute(req);
  const v1::ComputeRequest m = server.service().received().at(0);
  EXPECT_EQ(m.precision(), v1::PRECISION_AUTO);
  EXPECT_EQ(m.input_kind(), v1::INPUT_KIND_TAU);
  EXPECT_EQ(m.backend(), v1::BACKEND_AUTO);
  EXPECT_EQ(m.output_type(), v1::SCALAR_TYPE_F64);
  EXPECT_FALSE(m.has_minv());
  EXPECT_FALSE(m.has_fext());
  EXPECT_TRUE(m.request_id().empty());
}

// the session reuses one message: an optional input of step 1 must not leak into step 2
TEST(ClientRequestEncoding, ASessionDoesNotCarryOptionalInputsOver) {
  FakeServer server;
  Client client(server.address());
  const TestBatch batch(1, 2);
  std::vector<double> minv(4, 1.0);
  ComputeSession session = client.open_session();
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kQdd);
  req.minv = minv;
  (void)session.step(req);
  req.minv = {};
  req.q = std::span<const double>(batch.qd);  // other values in the same buffers
  (void)session.step(req);
  ASSERT_TRUE(session.close());
  const auto got = server.service().received();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(got[0].has_minv());
  EXPECT_FALSE(got[1].has_minv());
  EXPECT_EQ(doubles_of(got[1].q()), batch.qd);
}

TEST(ClientRequestEncoding, UnknownOutputBitsAreRefusedBeforeSending) {
  FakeServer server;
  Client client(server.address());
  const TestBatch batch(1, 2);
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kQdd) | 256u;
  ComputeResult result;
  const RpcStatus st = client.compute(req, result);
  EXPECT_EQ(st.code(), RpcCode::kInvalidArgument);
  EXPECT_NE(st.message().find("client: outputs has bits that name no output (256"), std::string::npos) << st.message();
  EXPECT_FALSE(result.valid());
  EXPECT_TRUE(server.service().received().empty());
}

TEST(ClientRequestEncoding, TheCallsDeadlineReachesTheServer) {
  FakeServer server;
  ClientOptions options;
  options.default_timeout = std::chrono::seconds(3);
  Client client(server.address(), options);
  const TestBatch batch(1, 2);
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kQdd);
  (void)client.compute(req);
  EXPECT_GT(server.service().last_time_left(), std::chrono::milliseconds(2000));
  // gRPC rounds the timeout it sends up to its wire unit: a few ms of slack
  EXPECT_LE(server.service().last_time_left(), std::chrono::milliseconds(3050));
  // a request's own timeout wins over the default
  req.timeout = std::chrono::milliseconds(700);
  (void)client.compute(req);
  EXPECT_GT(server.service().last_time_left(), std::chrono::milliseconds(200));
  EXPECT_LE(server.service().last_time_left(), std::chrono::milliseconds(750));
}

}  // namespace
}  // namespace rbdgrad::testing
