// Tests for server/request_batch.cpp.
#include "request_batch.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

constexpr int kNv = 7;
constexpr uint32_t kN = 3;
constexpr uint32_t kMaxStates = 65536;

// f64 bytes of `values`, as a client puts them on the wire
std::string f64_bytes(const std::vector<double>& values) {
  std::string s(values.size() * sizeof(double), '\0');
  std::memcpy(s.data(), values.data(), s.size());
  return s;
}

std::vector<double> ramp(size_t count, double start, double step) {
  std::vector<double> v(count);
  for (size_t i = 0; i < count; ++i) v[i] = start + step * static_cast<double>(i);
  return v;
}

void set_f64(v1::Tensor* t, const std::vector<double>& values) {
  t->set_type(v1::SCALAR_TYPE_F64);
  t->set_data(f64_bytes(values));
}

// a valid request: N=3 states of a 7-joint model, tau input, QDD and DTAU_DQ outputs
v1::ComputeRequest valid_request() {
  v1::ComputeRequest req;
  req.set_request_id("abc");
  req.set_num_states(kN);
  req.set_input_kind(v1::INPUT_KIND_TAU);
  req.add_outputs(v1::OUTPUT_QDD);
  req.add_outputs(v1::OUTPUT_DTAU_DQ);
  set_f64(req.mutable_q(), ramp(kN * kNv, -1.0, 0.125));
  set_f64(req.mutable_qd(), ramp(kN * kNv, 0.5, -0.0625));
  set_f64(req.mutable_u(), ramp(kN * kNv, 10.0, 0.25));
  return req;
}

template <typename T>
T at(const void* p, size_t i) {
  T v;
  std::memcpy(&v, static_cast<const char*>(p) + i * sizeof(T), sizeof(T));
  return v;
}

// expects invalid_argument whose message holds every fragment
void expect_error(const v1::ComputeRequest& req, std::initializer_list<std::string> fragments,
                  rbdgrad_precision precision = RBDGRAD_PRECISION_F64) {
  RequestBatch rb;
  const Status s = RequestBatch::from_request(req, kNv, precision, kMaxStates, rb);
  ASSERT_FALSE(s.is_ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << s.to_string();
  for (const std::string& f : fragments) EXPECT_NE(s.message().find(f), std::string::npos) << s.message();
  // a failed conversion leaves the batch empty
  EXPECT_EQ(rb.batch().n, 0u);
}

TEST(RequestBatchTest, OutputFlagsFollowThePluginBits) {
  EXPECT_EQ(output_flag(v1::OUTPUT_QDD), uint32_t{RBDGRAD_OUTPUT_QDD});
  EXPECT_EQ(output_flag(v1::OUTPUT_MINV), uint32_t{RBDGRAD_OUTPUT_MINV});
  EXPECT_EQ(output_flag(v1::OUTPUT_DQDD_DQD), uint32_t{RBDGRAD_OUTPUT_DQDD_DQD});
  EXPECT_EQ(output_flag(v1::OUTPUT_DTAU_DQD), uint32_t{RBDGRAD_OUTPUT_DTAU_DQD});
  EXPECT_EQ(output_flag(v1::OUTPUT_M), uint32_t{RBDGRAD_OUTPUT_M});
  EXPECT_EQ(output_flag(v1::OUTPUT_UNSPECIFIED), 0u);
}

TEST(RequestBatchTest, ConvertsF64Exactly) {
  RequestBatch rb;
  ASSERT_TRUE(RequestBatch::from_request(valid_request(), kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb).is_ok());
  const rbdgrad_batch& b = rb.batch();
  EXPECT_EQ(b.struct_size, sizeof(rbdgrad_batch));
  EXPECT_EQ(b.n, kN);
  EXPECT_EQ(b.precision, uint32_t{RBDGRAD_PRECISION_F64});
  EXPECT_EQ(b.input_kind, uint32_t{RBDGRAD_INPUT_TAU});
  EXPECT_EQ(b.outputs, uint32_t{RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DTAU_DQ});
  EXPECT_EQ(at<double>(b.q, 0), -1.0);
  EXPECT_EQ(at<double>(b.q, 20), -1.0 + 20 * 0.125);
  EXPECT_EQ(at<double>(b.qd, 9), 0.5 - 9 * 0.0625);
  EXPECT_EQ(at<double>(b.u, 13), 10.0 + 13 * 0.25);
  // absent optional inputs and unrequested outputs are NULL
  EXPECT_EQ(b.minv, nullptr);
  EXPECT_EQ(b.fext, nullptr);
  EXPECT_EQ(b.tau, nullptr);
  EXPECT_EQ(b.m, nullptr);
  EXPECT_NE(b.qdd, nullptr);
  EXPECT_NE(b.dtau_dq, nullptr);
  ASSERT_NE(b.state_status, nullptr);
  EXPECT_EQ(b.state_status[kN - 1], 0);
}

TEST(RequestBatchTest, ConvertsToF32) {
  v1::ComputeRequest req = valid_request();
  req.set_input_kind(v1::INPUT_KIND_QDD);
  RequestBatch rb;
  ASSERT_TRUE(RequestBatch::from_request(req, kNv, RBDGRAD_PRECISION_F32, kMaxStates, rb).is_ok());
  const rbdgrad_batch& b = rb.batch();
  EXPECT_EQ(b.precision, uint32_t{RBDGRAD_PRECISION_F32});
  EXPECT_EQ(b.input_kind, uint32_t{RBDGRAD_INPUT_QDD});
  EXPECT_EQ(at<float>(b.q, 0), -1.0f);
  EXPECT_EQ(at<float>(b.q, 20), 1.5f);
  EXPECT_EQ(at<float>(b.u, 13), 13.25f);
}

TEST(RequestBatchTest, ConvertsToFixedQ16_16) {
  v1::ComputeRequest req = valid_request();
  std::vector<double> q = ramp(kN * kNv, -1.0, 0.125);
  q[5] = 32767.99;      // the largest accepted magnitude
  q[6] = -1.0 / 65536;  // one LSB
  set_f64(req.mutable_q(), q);
  RequestBatch rb;
  ASSERT_TRUE(RequestBatch::from_request(req, kNv, RBDGRAD_PRECISION_FIXED_Q16_16, kMaxStates, rb).is_ok());
  const rbdgrad_batch& b = rb.batch();
  EXPECT_EQ(at<int32_t>(b.q, 0), -65536);
  EXPECT_EQ(at<int32_t>(b.q, 4), -32768);  // -0.5
  EXPECT_EQ(at<int32_t>(b.q, 5), static_cast<int32_t>(std::llround(32767.99 * 65536)));
  EXPECT_EQ(at<int32_t>(b.q, 6), -1);
  EXPECT_EQ(at<int32_t>(b.u, 1), static_cast<int32_t>(10.25 * 65536));
}

TEST(RequestBatchTest, AcceptsF32InputAndOptionalFields) {
  v1::ComputeRequest req = valid_request();
  std::vector<float> qd(kN * kNv, 0.75f);
  req.mutable_qd()->set_type(v1::SCALAR_TYPE_F32);
  req.mutable_qd()->set_data(std::string(reinterpret_cast<const char*>(qd.data()), qd.size() * sizeof(float)));
  set_f64(req.mutable_minv(), ramp(kN * kNv * kNv, 0.0, 0.01));
  set_f64(req.mutable_fext(), ramp(kN * kNv * 6, 1.0, 1.0));
  RequestBatch rb;
  ASSERT_TRUE(RequestBatch::from_request(req, kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb).is_ok());
  const rbdgrad_batch& b = rb.batch();
  EXPECT_EQ(at<double>(b.qd, 11), 0.75);
  ASSERT_NE(b.minv, nullptr);
  ASSERT_NE(b.fext, nullptr);
  EXPECT_EQ(at<double>(b.minv, 100), 100 * 0.01);
  EXPECT_EQ(at<double>(b.fext, 125), 126.0);
}

TEST(RequestBatchTest, RejectsBadRequestWideFields) {
  v1::ComputeRequest req = valid_request();
  req.set_num_states(0);
  expect_error(req, {"request 'abc': num_states is 0"});

  req = valid_request();
  req.set_num_states(70000);
  expect_error(req, {"request 'abc': num_states 70000 exceeds the limit max_states_per_request = 65536"});

  req = valid_request();
  req.set_input_kind(v1::INPUT_KIND_UNSPECIFIED);
  expect_error(req, {"request 'abc'", "input_kind", "INPUT_KIND_UNSPECIFIED"});

  req = valid_request();
  req.clear_outputs();
  expect_error(req, {"request 'abc'", "no outputs"});

  req = valid_request();
  req.add_outputs(v1::OUTPUT_UNSPECIFIED);
  expect_error(req, {"request 'abc'", "outputs[2]", "OUTPUT_UNSPECIFIED"});

  req = valid_request();
  req.add_outputs(v1::OUTPUT_QDD);
  expect_error(req, {"request 'abc'", "OUTPUT_QDD", "more than once"});

  // AUTO (or any non-precision) must be resolved by the caller
  expect_error(valid_request(), {"request 'abc'", "AUTO"}, static_cast<rbdgrad_precision>(0));
}

TEST(RequestBatchTest, RejectsBadTensorShapes) {
  v1::ComputeRequest req = valid_request();
  req.set_num_states(7);
  set_f64(req.mutable_q(), ramp(48, 0.0, 0.0));
  expect_error(req, {"request 'abc': field 'q' has 48 values, expected 49 (num_states 7 x nv 7)"});

  req = valid_request();
  req.mutable_qd()->set_type(v1::SCALAR_TYPE_UNSPECIFIED);
  expect_error(req, {"request 'abc': field 'qd' has type SCALAR_TYPE_UNSPECIFIED"});

  req = valid_request();
  req.mutable_u()->mutable_data()->push_back('\0');
  expect_error(req, {"request 'abc': field 'tau'", "not a multiple of 8"});

  req = valid_request();
  req.clear_qd();
  expect_error(req, {"field 'qd' has 0 values, expected 21"});

  req = valid_request();
  set_f64(req.mutable_minv(), ramp(kN * kNv * kNv - 1, 0.0, 0.0));
  expect_error(req, {"field 'minv' has 146 values, expected 147 (num_states 3 x nv 7 x nv 7)"});

  req = valid_request();
  set_f64(req.mutable_fext(), ramp(kN * kNv, 0.0, 0.0));
  expect_error(req, {"field 'fext' has 21 values, expected 126 (num_states 3 x nv 7 x 6)"});
}

TEST(RequestBatchTest, RejectsBadValuesNamingStateAndElement) {
  v1::ComputeRequest req = valid_request();
  req.set_num_states(5);
  set_f64(req.mutable_q(), ramp(5 * kNv, 0.0, 0.0));
  set_f64(req.mutable_qd(), ramp(5 * kNv, 0.0, 0.0));
  std::vector<double> u(5 * kNv, 1.0);
  u[3 * kNv + 2] = std::numeric_limits<double>::quiet_NaN();
  set_f64(req.mutable_u(), u);
  expect_error(req, {"request 'abc': state 3: field 'tau' element 2 is not finite (nan)"});

  req = valid_request();
  std::vector<double> q(kN * kNv, 0.0);
  q[1 * kNv + 4] = 40000.0;
  set_f64(req.mutable_q(), q);
  // fine in F64, out of range in Q16.16
  RequestBatch rb;
  EXPECT_TRUE(RequestBatch::from_request(req, kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb).is_ok());
  expect_error(req, {"request 'abc': state 1: field 'q' element 4", "outside the range of Q16.16"},
               RBDGRAD_PRECISION_FIXED_Q16_16);
}

TEST(RequestBatchTest, OmitsThePrefixWithoutARequestId) {
  v1::ComputeRequest req = valid_request();
  req.clear_request_id();
  req.set_num_states(0);
  RequestBatch rb;
  const Status s = RequestBatch::from_request(req, kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb);
  EXPECT_EQ(s.message(), "num_states is 0");
}

// fills every requested output buffer with value(i) in the batch's precision
void fill_outputs(RequestBatch& rb, double scale) {
  rbdgrad_batch& b = rb.mutable_batch();
  const size_t vec = b.n * kNv;
  const auto fill = [&](void* p, size_t count) {
    for (size_t i = 0; i < count; ++i) {
      const double v = scale * static_cast<double>(i);
      char* dst = static_cast<char*>(p);
      if (b.precision == RBDGRAD_PRECISION_F64) {
        std::memcpy(dst + i * 8, &v, 8);
      } else if (b.precision == RBDGRAD_PRECISION_F32) {
        const float f = static_cast<float>(v);
        std::memcpy(dst + i * 4, &f, 4);
      } else {
        const auto raw = static_cast<int32_t>(std::llround(v * 65536));
        std::memcpy(dst + i * 4, &raw, 4);
      }
    }
  };
  fill(b.qdd, vec);
  fill(b.dtau_dq, vec * kNv);
}

TEST(RequestBatchTest, ToResponseWritesF64) {
  RequestBatch rb;
  ASSERT_TRUE(RequestBatch::from_request(valid_request(), kNv, RBDGRAD_PRECISION_F32, kMaxStates, rb).is_ok());
  fill_outputs(rb, 0.5);
  v1::ComputeResponse resp;
  rb.to_response(resp, v1::SCALAR_TYPE_UNSPECIFIED);  // UNSPECIFIED means F64
  EXPECT_EQ(resp.request_id(), "abc");
  EXPECT_EQ(resp.num_states(), kN);
  EXPECT_EQ(resp.precision(), v1::PRECISION_F32);
  EXPECT_EQ(resp.qdd().type(), v1::SCALAR_TYPE_F64);
  ASSERT_EQ(resp.qdd().data().size(), kN * kNv * sizeof(double));
  ASSERT_EQ(resp.dtau_dq().data().size(), kN * kNv * kNv * sizeof(double));
  EXPECT_EQ(at<double>(resp.qdd().data().data(), 20), 10.0);
  EXPECT_EQ(at<double>(resp.dtau_dq().data().data(), 146), 73.0);
  // unrequested outputs stay empty
  EXPECT_TRUE(resp.tau().data().empty());
  EXPECT_FALSE(resp.has_m());
}

TEST(RequestBatchTest, F64OutputsGoStraightIntoTheResponse) {
  v1::ComputeResponse resp;
  RequestBatch rb;
  ASSERT_TRUE(
      RequestBatch::from_request(valid_request(), kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb, &resp).is_ok());
  // the backend's output arrays are the response's tensors
  EXPECT_EQ(rb.batch().qdd, static_cast<const void*>(resp.qdd().data().data()));
  EXPECT_EQ(rb.batch().dtau_dq, static_cast<const void*>(resp.dtau_dq().data().data()));
  fill_outputs(rb, 0.5);
  rb.to_response(resp, v1::SCALAR_TYPE_UNSPECIFIED);
  EXPECT_EQ(resp.qdd().type(), v1::SCALAR_TYPE_F64);
  ASSERT_EQ(resp.dtau_dq().data().size(), kN * kNv * kNv * sizeof(double));
  EXPECT_EQ(at<double>(resp.qdd().data().data(), 20), 10.0);
  EXPECT_EQ(at<double>(resp.dtau_dq().data().data(), 146), 73.0);
  EXPECT_FALSE(resp.has_m());

  // an F32 wire or compute precision still goes through the batch's own buffers
  v1::ComputeRequest f32_out = valid_request();
  f32_out.set_output_type(v1::SCALAR_TYPE_F32);
  v1::ComputeResponse other;
  ASSERT_TRUE(RequestBatch::from_request(f32_out, kNv, RBDGRAD_PRECISION_F64, kMaxStates, rb, &other).is_ok());
  EXPECT_FALSE(other.has_qdd());
  ASSERT_TRUE(RequestBatch::from_request(valid_request(), kNv, RBDGRAD_PRECISION_F32, kMaxStates, rb, &other).is_ok());
  EXPECT_FALSE(other.has_qdd());
}

TEST(RequestBatchTest, ToResponseWritesF32FromFixed) {
  RequestBatch rb;
  ASSERT_TRUE(
      RequestBatch::from_request(valid_request(), kNv, RBDGRAD_PRECISION_FIXED_Q16_16, kMaxStates, rb).is_ok());
  fill_outputs(rb, 0.25);
  v1::ComputeResponse resp;
  rb.to_response(resp, v1::SCALAR_TYPE_F32);
  EXPECT_EQ(resp.precision(), v1::PRECISION_FIXED);
  EXPECT_EQ(resp.dtau_dq().type(), v1::SCALAR_TYPE_F32);
  ASSERT_EQ(resp.qdd().data().size(), kN * kNv * sizeof(float));
  ASSERT_EQ(resp.dtau_dq().data().size(), kN * kNv * kNv * sizeof(float));
  EXPECT_EQ(at<float>(resp.qdd().data().data(), 3), 0.75f);
  EXPECT_EQ(at<float>(resp.dtau_dq().data().data(), 100), 25.0f);
}

}  // namespace
}  // namespace rbdgrad::server
