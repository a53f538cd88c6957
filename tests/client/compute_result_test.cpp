// Tests for client/src/compute_result.cpp: views onto a response (values, state offsets, layout,
// f32 outputs), the metadata, buffer reuse, and the errors of a misused or malformed result.
#include <gtest/gtest.h>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"
#include "test_batch.hpp"

namespace rbdgrad::testing {
namespace {

constexpr std::uint32_t kAll = 255;

class ComputeResultTest : public ::testing::Test {
 protected:
  FakeServer server_;
  Client client_{server_.address()};
};

TEST_F(ComputeResultTest, EveryOutputOfEveryStateMapsTheResponse) {
  const TestBatch batch(5, 3);
  ComputeRequest req = batch.request();
  req.outputs = kAll;
  req.request_id = "views";
  const ComputeResult r = client_.compute(req);
  ASSERT_TRUE(r.valid());
  EXPECT_EQ(r.num_states(), 5u);
  EXPECT_EQ(r.nv(), 3);
  EXPECT_EQ(r.outputs(), kAll);
  EXPECT_EQ(check_result_values(r, batch), "");
  // row-major: (i, j) of state k is element k*nv*nv + i*nv + j of the block
  const std::span<const double> block = r.block(Output::kDqddDq);
  ASSERT_EQ(block.size(), 5u * 9u);
  EXPECT_EQ(block[4 * 9 + 1 * 3 + 2], batch.expected(Output::kDqddDq, 4, 1, 2));
  EXPECT_EQ(r.dqdd_dq(4)(1, 2), block[4 * 9 + 1 * 3 + 2]);
  EXPECT_EQ(r.block(Output::kQdd).size(), 15u);
  // the shorthands are the same views
  EXPECT_EQ(r.qdd(2).data(), r.vector(Output::kQdd, 2).data());
  EXPECT_EQ(r.m(1).data(), r.matrix(Output::kM, 1).data());
  EXPECT_EQ(r.tau(3)(0), batch.expected(Output::kTau, 3, 0));
  EXPECT_EQ(r.minv(0)(2, 1), batch.expected(Output::kMinv, 0, 2, 1));
  EXPECT_EQ(r.dqdd_dqd(1)(0, 2), batch.expected(Output::kDqddDqd, 1, 0, 2));
  EXPECT_EQ(r.dtau_dq(2)(1, 1), batch.expected(Output::kDtauDq, 2, 1, 1));
  EXPECT_EQ(r.dtau_dqd(3)(2, 0), batch.expected(Output::kDtauDqd, 3, 2, 0));
  // views, not copies: consecutive states are nv*nv doubles apart in one block
  EXPECT_EQ(r.dqdd_dq(1).data(), r.dqdd_dq(0).data() + 9);
  EXPECT_EQ(r.dqdd_dq(0).data(), block.data());
}

TEST_F(ComputeResultTest, MetadataComesFromTheResponse) {
  const TestBatch batch(2, 2);
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kQdd);
  req.request_id = "meta-7";
  req.backend = Backend::kFpga;
  req.precision = Precision::kFixed;
  const ComputeResult r = client_.compute(req);
  EXPECT_EQ(r.request_id(), "meta-7");
  EXPECT_EQ(r.backend(), Backend::kFpga);
  EXPECT_EQ(r.precision(), Precision::kFixed);
  EXPECT_EQ(r.output_type(), ScalarType::kF64);
  EXPECT_EQ(r.timings().queue_us, kQueueUs);
  EXPECT_EQ(r.timings().compute_us, kComputeUs);
  EXPECT_EQ(r.timings().total_us, kTotalUs);
  EXPECT_GT(r.timings().round_trip_us, 0.0);
  EXPECT_LT(r.timings().round_trip_us, 5e6);
  // auto: the server says what it used
  req.backend = Backend::kAuto;
  req.precision = Precision::kAuto;
  const ComputeResult a = client_.compute(req);
  EXPECT_EQ(a.backend(), Backend::kCpu);
  EXPECT_EQ(a.precision(), Precision::kF64);
  EXPECT_TRUE(a.parts().empty());
  // a request the server split across backends lists the shares
  req.request_id = "split";
  const ComputeResult split = client_.compute(req);
  const std::vector<ComputePart> parts = split.parts();
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].backend, Backend::kCpu);
  EXPECT_EQ(parts[0].first_state, 0u);
  EXPECT_EQ(parts[0].num_states, 1u);
  EXPECT_EQ(parts[0].compute_us, 10u);
  EXPECT_EQ(parts[1].backend, Backend::kCuda);
  EXPECT_EQ(parts[1].first_state, 1u);
  EXPECT_EQ(parts[1].num_states, 1u);
  EXPECT_EQ(parts[1].compute_us, 11u);
}

TEST_F(ComputeResultTest, F32OutputsHaveTheirOwnViews) {
  const TestBatch batch(3, 4);
  ComputeRequest req = batch.request();
  req.outputs = Output::kQdd | Output::kDtauDqd;
  req.output_type = ScalarType::kF32;
  const ComputeResult r = client_.compute(req);
  EXPECT_EQ(r.output_type(), ScalarType::kF32);
  EXPECT_EQ(check_result_values(r, batch), "");
  EXPECT_EQ(r.block_f32(Output::kDtauDqd).size(), 3u * 16u);
  EXPECT_FLOAT_EQ(r.matrix_f32(Output::kDtauDqd, 2)(3, 1), static_cast<float>(batch.expected(Output::kDtauDqd, 2, 3, 1)));
  EXPECT_FLOAT_EQ(r.vector_f32(Output::kQdd, 1)(2), static_cast<float>(batch.expected(Output::kQdd, 1, 2)));
  // the f64 views refuse f32 data, and say what to use
  try {
    (void)r.qdd(0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("output 'qdd' holds f32 values"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)r.block(Output::kQdd), std::invalid_argument);
}

TEST_F(ComputeResultTest, MisuseIsAClearError) {
  const TestBatch batch(2, 3);
  ComputeRequest req = batch.request();
  req.outputs = Output::kQdd | Output::kM;
  const ComputeResult r = client_.compute(req);
  try {
    (void)r.dqdd_dq(0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "ComputeResult: output 'dqdd_dq' was not requested (the result holds qdd, m)");
  }
  try {
    (void)r.qdd(2);
    FAIL() << "no exception";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(), "ComputeResult: output 'qdd': state 2 of a result of 2 states");
  }
  EXPECT_THROW((void)r.matrix(Output::kQdd, 0), std::invalid_argument);
  EXPECT_THROW((void)r.vector(Output::kM, 0), std::invalid_argument);
  EXPECT_FALSE(r.has(Output::kTau));
  EXPECT_TRUE(r.has(Output::kM));

  const ComputeResult empty;
  EXPECT_FALSE(empty.valid());
  EXPECT_EQ(empty.num_states(), 0u);
  EXPECT_THROW((void)empty.qdd(0), std::invalid_argument);
}

TEST_F(ComputeResultTest, ACallIntoTheSameResultReusesIt) {
  ComputeResult r;
  const TestBatch big(8, 3), small(2, 3, 100.0);
  ComputeRequest req = big.request();
  req.outputs = kAll;
  ASSERT_TRUE(client_.compute(req, r));
  EXPECT_EQ(check_result_values(r, big), "");
  req = small.request();
  req.outputs = mask(Output::kDqddDq);
  ASSERT_TRUE(client_.compute(req, r));
  EXPECT_EQ(r.num_states(), 2u);
  EXPECT_EQ(r.outputs(), mask(Output::kDqddDq));
  EXPECT_EQ(check_result_values(r, small), "");
  // a failed call leaves the result invalid rather than stale
  req.model = "broken";
  EXPECT_FALSE(client_.compute(req, r));
  EXPECT_FALSE(r.valid());
  EXPECT_THROW((void)r.dqdd_dq(0), std::invalid_argument);
}

TEST_F(ComputeResultTest, AMalformedResponseIsAnInternalError) {
  const TestBatch batch(2, 3);
  ComputeRequest req = batch.request("short");
  req.outputs = Output::kQdd | Output::kDqddDq;
  ComputeResult r;
  const RpcStatus st = client_.compute(req, r);
  EXPECT_EQ(st.code(), RpcCode::kInternal);
  EXPECT_EQ(st.message(), "client: malformed response: output 'qdd' has 40 bytes, expected 48 (N 2, nv 3, f64)");
  EXPECT_FALSE(r.valid());
}

}  // namespace
}  // namespace rbdgrad::testing
