// Bad input through the real daemon: each case is refused with the right gRPC status and a message
// naming the request, state and field, and the daemon goes on serving the next request.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <cmath>
#include <future>
#include <limits>

#include "integration_support.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::HasSubstr;

constexpr std::uint32_t kGradient = Output::kDqddDq | Output::kDqddDqd;
constexpr int kMaxStates = 100;  // the limit configured below

class ServiceErrors : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string extra = "limits:\n  max_states_per_request: " + std::to_string(kMaxStates) + "\n";
#ifdef FAKE_CUDA_PLUGIN_PATH
    // a stand-in "cuda" backend that supports f64 and f32 only; it computes nothing, so timed it
    // would win every automatic route: without calibration, automatic requests go to the cpu
    extra += std::string("plugins:\n  - path: ") + FAKE_CUDA_PLUGIN_PATH + "\nscheduler:\n  calibrate: off\n";
#endif
    daemon_ = new DaemonProcess(RBDGRADD_PATH, daemon_config(extra));
  }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
  }

  void SetUp() override {
    client_ = std::make_unique<Client>(daemon_->tcp_address());
    model_ = load_embedded("iiwa14");
    batch_ = random_batch("iiwa14", model_.nv, 5, 7);
  }
  // the daemon still answers a good request, correctly
  void expect_still_serving() {
    const ComputeResult r = client_->compute(batch_.request(kGradient));
    EXPECT_TRUE(bitwise_equal(r, expected_outputs(model_, batch_, kGradient, true)));
  }
  RpcStatus call(const ComputeRequest& req) {
    ComputeResult out;
    return client_->compute(req, out);
  }

  static DaemonProcess* daemon_;
  std::unique_ptr<Client> client_;
  Model model_;
  Batch batch_;
};
DaemonProcess* ServiceErrors::daemon_ = nullptr;

TEST_F(ServiceErrors, UnknownModelIsNotFound) {
  ComputeRequest req = batch_.request(kGradient);
  req.model = "no_such_robot";
  const RpcStatus s = call(req);
  EXPECT_EQ(s.code(), RpcCode::kNotFound) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("no_such_robot"));
  expect_still_serving();
}

TEST_F(ServiceErrors, WrongArrayLengthNamesTheField) {
  std::vector<double> short_qd(batch_.qd.begin(), batch_.qd.end() - 1);
  ComputeRequest req = batch_.request(kGradient);
  req.qd = short_qd;
  req.request_id = "short-qd";
  const RpcStatus s = call(req);
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("short-qd"));
  EXPECT_THAT(s.message(), HasSubstr("field 'qd'"));
  EXPECT_THAT(s.message(), HasSubstr("34"));  // values received (5 x 7 - 1)
  expect_still_serving();
}

TEST_F(ServiceErrors, NanAndInfNameStateFieldAndElement) {
  Batch bad = batch_;
  bad.qd[3 * 7 + 2] = std::numeric_limits<double>::quiet_NaN();
  RpcStatus s = call(bad.request(kGradient));
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("state 3"));
  EXPECT_THAT(s.message(), HasSubstr("field 'qd' element 2"));

  bad = batch_;
  bad.u[4 * 7 + 6] = -std::numeric_limits<double>::infinity();
  s = call(bad.request(kGradient));
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("state 4"));
  EXPECT_THAT(s.message(), HasSubstr("field 'tau' element 6"));  // u is named for what it holds
  expect_still_serving();
}

TEST_F(ServiceErrors, ZeroStatesIsInvalid) {
  ComputeRequest req = batch_.request(kGradient);
  req.num_states = 0;
  req.q = req.qd = req.u = {};
  const RpcStatus s = call(req);
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("num_states"));
  expect_still_serving();
}

TEST_F(ServiceErrors, StatesAboveTheLimitAreRefusedNamingTheLimit) {
  const Batch big = random_batch("iiwa14", 7, kMaxStates + 1, 3);
  const RpcStatus s = call(big.request(kGradient));
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr(std::to_string(kMaxStates)));
  // the limit itself is fine
  const Batch at_limit = random_batch("iiwa14", 7, kMaxStates, 3);
  ComputeResult r;
  EXPECT_TRUE(client_->compute(at_limit.request(kGradient), r));
  expect_still_serving();
}

TEST_F(ServiceErrors, NoOutputsIsInvalid) {
  const RpcStatus s = call(batch_.request(0));
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  expect_still_serving();
}

TEST_F(ServiceErrors, BackendThatIsNotLoadedIsUnavailable) {
  ComputeRequest req = batch_.request(kGradient);
  req.backend = Backend::kFpga;
  const RpcStatus s = call(req);
  EXPECT_EQ(s.code(), RpcCode::kUnavailable) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("fpga"));
  expect_still_serving();
}

TEST_F(ServiceErrors, PrecisionTheHintedBackendLacksIsRefused) {
#ifndef FAKE_CUDA_PLUGIN_PATH
  GTEST_SKIP() << "no fake cuda plugin built";
#else
  ComputeRequest req = batch_.request(kGradient, ComputeInput::kTau, Precision::kFixed);
  req.backend = Backend::kCuda;
  const RpcStatus s = call(req);
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("cuda"));
  EXPECT_THAT(s.message(), HasSubstr("fixed"));
  // the same precision on the CPU backend is served
  req.backend = Backend::kCpu;
  ComputeResult r;
  const RpcStatus cpu = client_->compute(req, r);
  EXPECT_TRUE(cpu || cpu.code() == RpcCode::kOutOfRange) << cpu.to_string();  // Q16.16 may overflow
  expect_still_serving();
#endif
}

TEST_F(ServiceErrors, MalformedMessageIsRefused) {
  // bytes that are not a ComputeRequest (a truncated length-delimited field), sent as raw bytes
  auto channel = grpc::CreateChannel(daemon_->tcp_address(), grpc::InsecureChannelCredentials());
  grpc::GenericStub stub(channel);
  const char garbage[] = "\x32\xff\xff\xff\x0f garbage";
  grpc::Slice slice(garbage, sizeof(garbage) - 1);
  const grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer response;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, "/rbdgrad.v1.Dynamics/Compute", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) { done.set_value(std::move(s)); });
  const grpc::Status s = done.get_future().get();
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << s.error_message();
  EXPECT_NE(s.error_code(), grpc::StatusCode::UNAVAILABLE) << s.error_message();
  expect_still_serving();
}

TEST_F(ServiceErrors, BadRequestOnAStreamEndsItWithTheStatus) {
  ComputeSession session = client_->open_session();
  ComputeResult out;
  ASSERT_TRUE(session.step(batch_.request(kGradient), out));
  Batch bad = batch_;
  bad.q[0] = std::numeric_limits<double>::quiet_NaN();
  ComputeRequest req = bad.request(kGradient);
  req.request_id = "step-2";
  const RpcStatus s = session.step(req, out);
  EXPECT_EQ(s.code(), RpcCode::kInvalidArgument) << s.to_string();
  EXPECT_THAT(s.message(), HasSubstr("step-2"));
  EXPECT_THAT(s.message(), HasSubstr("state 0"));
  EXPECT_FALSE(session.is_open());
  expect_still_serving();
}

}  // namespace
}  // namespace rbdgrad::testing
