// Tests for plugins/common/batch_view.{hpp,cpp}: layouts, fixed-point conversion, validation.
#include "common/batch_view.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

#include "../support/plugin_harness.hpp"

namespace rbdgrad::plugin {
namespace {

using ::testing::HasSubstr;
using testing::BatchArrays;

constexpr int kNv = 3;

TEST(BatchView, MapsStateKOfEachInput) {
  BatchArrays<double> a(2, kNv);
  for (std::size_t i = 0; i < a.q.size(); ++i) {
    a.q[i] = static_cast<double>(i);
    a.qd[i] = 10.0 + static_cast<double>(i);
    a.u[i] = 20.0 + static_cast<double>(i);
  }
  for (std::size_t i = 0; i < a.fext.size(); ++i) a.fext[i] = 100.0 + static_cast<double>(i);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_QDD, false, true);
  const BatchView<double> view(b, kNv);
  StateBuffers<double> buf(kNv);
  const StateInputs<double> in = view.inputs(1, buf);
  EXPECT_EQ(in.q, Eigen::Vector3d(3, 4, 5));
  EXPECT_EQ(in.qd, Eigen::Vector3d(13, 14, 15));
  EXPECT_EQ(in.u, Eigen::Vector3d(23, 24, 25));
  EXPECT_EQ(in.q.data(), a.q.data() + 3);  // floating point: no copy
  ASSERT_NE(in.fext, nullptr);
  EXPECT_EQ(in.fext[0], 118.0);  // body 0 of state 1 starts at 1 * nv * 6
  EXPECT_EQ(in.minv, nullptr);
}

// states_of: every array starts at state `first`, in the batch's precision; absent ones stay absent.
TEST(StatesOf, PointsEveryArrayAtTheFirstStateOfThePart) {
  BatchArrays<float> a(5, kNv);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F32, RBDGRAD_INPUT_TAU, kAllOutputs, true, false);
  const rbdgrad_batch part = states_of(b, kNv, 2, 3);
  EXPECT_EQ(part.n, 3u);
  EXPECT_EQ(part.precision, b.precision);
  EXPECT_EQ(part.outputs, b.outputs);
  EXPECT_EQ(part.q, a.q.data() + 2 * kNv);
  EXPECT_EQ(part.qd, a.qd.data() + 2 * kNv);
  EXPECT_EQ(part.u, a.u.data() + 2 * kNv);
  EXPECT_EQ(part.minv, a.minv.data() + 2 * kNv * kNv);
  EXPECT_EQ(part.fext, nullptr);
  for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1) {
    const std::size_t per_state = (flag & kMatrixOutputs) ? kNv * kNv : kNv;
    EXPECT_EQ(output_pointer(part, flag), a.out(flag).data() + 2 * per_state) << output_name(flag);
  }
  EXPECT_EQ(part.state_status, a.state_status.data() + 2);
  BatchArrays<double> d(4, kNv);
  const rbdgrad_batch with_fext = states_of(d.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_QDD, RBDGRAD_OUTPUT_TAU, false, true), kNv, 3, 1);
  EXPECT_EQ(with_fext.fext, d.fext.data() + 3 * 6 * kNv);
  EXPECT_EQ(with_fext.minv, nullptr);
  EXPECT_EQ(with_fext.tau, d.out(RBDGRAD_OUTPUT_TAU).data() + 3 * kNv);
}

TEST(BatchView, ReadsTheSuppliedMinvRowMajorEvenWhenUnsymmetric) {
  BatchArrays<float> a(2, kNv);
  for (std::size_t i = 0; i < a.minv.size(); ++i) a.minv[i] = static_cast<float>(i);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F32, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_DQDD_DQ, true, false);
  const BatchView<float> view(b, kNv);
  StateBuffers<float> buf(kNv);
  const StateInputs<float> in = view.inputs(1, buf);
  ASSERT_EQ(in.minv, &buf.minv);
  for (int i = 0; i < kNv; ++i)
    for (int j = 0; j < kNv; ++j) EXPECT_EQ((*in.minv)(i, j), static_cast<float>(9 + i * kNv + j)) << i << "," << j;
}

TEST(BatchView, WritesColumnMajorMatricesRowMajor) {
  BatchArrays<double> a(2, kNv);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_TAU, false, false);
  const BatchView<double> view(b, kNv);
  Eigen::Matrix3d m;
  m << 1, 2, 3, 4, 5, 6, 7, 8, 9;
  view.write(RBDGRAD_OUTPUT_DTAU_DQ, 1, Eigen::MatrixXd(m));
  view.write(RBDGRAD_OUTPUT_TAU, 1, Eigen::VectorXd(Eigen::Vector3d(-1, -2, -3)));
  const std::vector<double>& out = a.out(RBDGRAD_OUTPUT_DTAU_DQ);
  for (int k = 0; k < 9; ++k) EXPECT_EQ(out[9 + k], k + 1.0);  // element (i, j) at i * nv + j
  for (int k = 0; k < 9; ++k) EXPECT_EQ(out[k], 77.0);          // state 0 untouched
  EXPECT_EQ(a.out(RBDGRAD_OUTPUT_TAU), (std::vector<double>{77, 77, 77, -1, -2, -3}));
  view.set_status(1, 3);
  EXPECT_EQ(a.state_status[1], 3);
}

TEST(BatchView, FixedPointTravelsAsRawQ16_16) {
  BatchArrays<std::int32_t> a(1, kNv);
  a.q = {65536, -32768, 1};  // 1.0, -0.5, one LSB
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_QDD, false, false);
  const BatchView<Q16_16> view(b, kNv);
  StateBuffers<Q16_16> buf(kNv);
  const StateInputs<Q16_16> in = view.inputs(0, buf);
  EXPECT_EQ(in.q(0).to_double(), 1.0);
  EXPECT_EQ(in.q(1).to_double(), -0.5);
  EXPECT_EQ(in.q(2).raw(), 1);
  VectorX<Q16_16> qdd(kNv);
  qdd << Q16_16(0.25), Q16_16(-2.0), Q16_16::from_raw(-7);
  view.write(RBDGRAD_OUTPUT_QDD, 0, qdd);
  EXPECT_EQ(a.out(RBDGRAD_OUTPUT_QDD), (std::vector<std::int32_t>{16384, -131072, -7}));
}

TEST(ValidateBatch, AcceptsAGoodBatchAndNamesBadFields) {
  BatchArrays<double> a(2, kNv);
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_QDD, kAllOutputs, true, true);
  EXPECT_TRUE(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).is_ok());
  EXPECT_THAT(validate_batch(nullptr, kNv, kAllPrecisions, kAllOutputs).message(), HasSubstr("batch is NULL"));

  // a backend without fixed point or without M^-1 says UNSUPPORTED (unimplemented)
  b.precision = RBDGRAD_PRECISION_FIXED_Q16_16;
  Status s = validate_batch(&b, kNv, RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32, kAllOutputs);
  EXPECT_EQ(s.code(), StatusCode::kUnimplemented);
  EXPECT_THAT(s.message(), HasSubstr("batch.precision fixed_q16_16 is not supported"));
  b.precision = RBDGRAD_PRECISION_F64;
  s = validate_batch(&b, kNv, kAllPrecisions, kAllOutputs & ~RBDGRAD_OUTPUT_MINV);
  EXPECT_EQ(s.code(), StatusCode::kUnimplemented);
  EXPECT_THAT(s.message(), HasSubstr("RBDGRAD_OUTPUT_MINV is not supported"));

  b.tau = nullptr;
  EXPECT_THAT(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).message(),
              HasSubstr("batch.tau is NULL but RBDGRAD_OUTPUT_TAU is requested"));
  b.outputs = RBDGRAD_OUTPUT_QDD;  // tau is not asked for any more
  EXPECT_TRUE(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).is_ok());
  b.fext = reinterpret_cast<const char*>(b.fext) + 4;
  EXPECT_THAT(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).message(),
              HasSubstr("batch.fext is not aligned to 8 bytes"));
}

TEST(ValidateBatch, MassMatrixAloneNeedsOnlyQ) {
  BatchArrays<float> a(1, kNv);
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F32, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_M, false, false);
  b.qd = b.u = nullptr;
  EXPECT_TRUE(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).is_ok());
  b.outputs |= RBDGRAD_OUTPUT_TAU;
  EXPECT_THAT(validate_batch(&b, kNv, kAllPrecisions, kAllOutputs).message(), HasSubstr("batch.qd is NULL"));
}

TEST(CheckRequest, KnownPrecisionAndOutputs) {
  EXPECT_TRUE(check_request(RBDGRAD_PRECISION_F32, RBDGRAD_OUTPUT_M, kAllPrecisions, kAllOutputs).is_ok());
  EXPECT_EQ(check_request(3, RBDGRAD_OUTPUT_M, kAllPrecisions, kAllOutputs).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(check_request(1, 0, kAllPrecisions, kAllOutputs).code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(check_request(1, 0x300, kAllPrecisions, kAllOutputs).message(), HasSubstr("unknown bits 0x300"));
}

}  // namespace
}  // namespace rbdgrad::plugin
