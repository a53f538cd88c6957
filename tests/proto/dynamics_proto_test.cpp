// Tests for proto/rbdgrad/v1/dynamics.proto: the generated code builds, and a batch travels as one
// contiguous little-endian block per field.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "rbdgrad/v1/dynamics.grpc.pb.h"
#include "rbdgrad/v1/dynamics.pb.h"

namespace {

TEST(DynamicsProto, ATensorCarriesTheBatchAsOneBlockAndRoundTrips) {
  const int n = 3, nv = 7;
  std::vector<double> q(static_cast<size_t>(n * nv));
  for (size_t k = 0; k < q.size(); ++k) q[k] = 0.1 * static_cast<double>(k) - 1.0;

  rbdgrad::v1::ComputeRequest request;
  request.set_model("iiwa14");
  request.set_num_states(n);
  request.set_precision(rbdgrad::v1::PRECISION_F64);
  request.set_input_kind(rbdgrad::v1::INPUT_KIND_TAU);
  request.add_outputs(rbdgrad::v1::OUTPUT_DQDD_DQ);
  request.mutable_q()->set_type(rbdgrad::v1::SCALAR_TYPE_F64);
  request.mutable_q()->set_data(q.data(), q.size() * sizeof(double));

  std::string wire;
  ASSERT_TRUE(request.SerializeToString(&wire));
  // the payload is the bulk of the message: no per-number framing
  EXPECT_LT(wire.size(), q.size() * sizeof(double) + 64);

  rbdgrad::v1::ComputeRequest parsed;
  ASSERT_TRUE(parsed.ParseFromString(wire));
  ASSERT_EQ(parsed.q().data().size(), q.size() * sizeof(double));
  std::vector<double> back(q.size());
  std::memcpy(back.data(), parsed.q().data().data(), parsed.q().data().size());
  EXPECT_EQ(back, q);
  EXPECT_EQ(parsed.outputs(0), rbdgrad::v1::OUTPUT_DQDD_DQ);
  EXPECT_EQ(parsed.model(), "iiwa14");
  // the generated stub exists for clients
  static_assert(sizeof(rbdgrad::v1::Dynamics::Stub) > 0);
}

TEST(DynamicsProto, TheServiceHasItsNineMethods) {
  const auto* service = rbdgrad::v1::ComputeRequest::descriptor()->file()->FindServiceByName("Dynamics");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ(service->method_count(), 9);
  EXPECT_NE(service->FindMethodByName("RegisterScene"), nullptr);
  EXPECT_NE(service->FindMethodByName("Calibrate"), nullptr);
  EXPECT_NE(service->FindMethodByName("ListScenes"), nullptr);
  EXPECT_NE(service->FindMethodByName("GetScene"), nullptr);
  EXPECT_NE(service->FindMethodByName("ComputeStream"), nullptr);
  EXPECT_TRUE(service->FindMethodByName("ComputeStream")->client_streaming());
  EXPECT_TRUE(service->FindMethodByName("ComputeStream")->server_streaming());
}

}  // namespace
