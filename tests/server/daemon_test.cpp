// Tests for server/daemon.cpp and the service behind it: one in-process Daemon on an ephemeral
// port (and a Unix socket), called through the generated stub and through generic calls for what
// the stub cannot send (garbage bytes) or does not cover (health, reflection).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <limits>
#include <map>
#include <thread>
#include <vector>

#include "daemon_test_support.hpp"
#include "message_size.hpp"
#include "model_source.hpp"
#include "request_batch.hpp"
#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/locked_joints.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;  // the shared helpers of daemon_test_support.hpp
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// One daemon for the tests that only talk to it.
class DaemonTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    daemon_ = start_daemon(test_options("shared.sock")).release();
    ASSERT_NE(daemon_, nullptr);
    channel_ = channel_to(daemon_->addresses()[0]);
  }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
    channel_.reset();
  }

  grpc::Status compute(const v1::ComputeRequest& req, v1::ComputeResponse* resp = nullptr) {
    auto stub = v1::Dynamics::NewStub(channel_);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
    v1::ComputeResponse local;
    return stub->Compute(&ctx, req, resp != nullptr ? resp : &local);
  }

  // the daemon still serves after a refused request
  void expect_still_serving() {
    v1::ComputeResponse resp;
    const grpc::Status s = compute(make_request("iiwa14", kIiwaNv, 2, 99, "after"), &resp);
    EXPECT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(resp.request_id(), "after");
  }

  void expect_refused(const v1::ComputeRequest& req, grpc::StatusCode code, const std::string& message) {
    const grpc::Status s = compute(req);
    EXPECT_EQ(s.error_code(), code) << s.error_message();
    EXPECT_EQ(s.error_message(), message);
    expect_still_serving();
  }

  static Daemon* daemon_;
  static std::shared_ptr<grpc::Channel> channel_;
};
Daemon* DaemonTest::daemon_ = nullptr;
std::shared_ptr<grpc::Channel> DaemonTest::channel_;

TEST_F(DaemonTest, ListensOnAnEphemeralPortAndTheUnixSocket) {
  ASSERT_EQ(daemon_->addresses().size(), 2u);
  EXPECT_GT(daemon_->tcp_port(), 0);
  EXPECT_EQ(daemon_->addresses()[0], (ListenAddress{"tcp", "127.0.0.1:" + std::to_string(daemon_->tcp_port())}));
  EXPECT_EQ(daemon_->addresses()[1].kind, "unix");
  auto stub = v1::Dynamics::NewStub(channel_to(daemon_->addresses()[1]));
  grpc::ClientContext ctx;
  v1::ListModelsResponse resp;
  ASSERT_TRUE(stub->ListModels(&ctx, v1::ListModelsRequest(), &resp).ok());
  EXPECT_EQ(resp.models_size(), 2);
}

TEST_F(DaemonTest, ComputeF64EqualsTheCoreLibraryBitForBit) {
  constexpr uint32_t kN = 16;
  const v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, kN, 1, "exact");
  v1::ComputeResponse resp;
  const grpc::Status s = compute(req, &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(resp.request_id(), "exact");
  EXPECT_EQ(resp.num_states(), kN);
  EXPECT_EQ(resp.backend(), v1::BACKEND_CPU);
  EXPECT_EQ(resp.precision(), v1::PRECISION_F64);
  EXPECT_LE(resp.timings().queue_us(), resp.timings().total_us());
  EXPECT_LE(resp.timings().compute_us(), resp.timings().total_us());

  // the reference: the core library, one state at a time, in this process
  Model model;
  ASSERT_TRUE(cli::load_model("iiwa14", std::nullopt, model).is_ok());
  Workspace ws(model);
  const std::vector<double> q = values_of(req.q()), qd = values_of(req.qd()), tau = values_of(req.u());
  const std::vector<double> qdd = values_of(resp.qdd()), minv = values_of(resp.minv()),
                            dqdd_dq = values_of(resp.dqdd_dq()), dqdd_dqd = values_of(resp.dqdd_dqd()),
                            tau_out = values_of(resp.tau()), dtau_dq = values_of(resp.dtau_dq()),
                            dtau_dqd = values_of(resp.dtau_dqd()), m = values_of(resp.m());
  ASSERT_EQ(qdd.size(), kN * kIiwaNv);
  ASSERT_EQ(m.size(), kN * kIiwaNv * kIiwaNv);
  const auto bits = [](double v) { return std::bit_cast<uint64_t>(v); };
  for (uint32_t k = 0; k < kN; ++k) {
    const Eigen::Map<const Eigen::VectorXd> qk(q.data() + k * kIiwaNv, kIiwaNv), qdk(qd.data() + k * kIiwaNv, kIiwaNv),
        tauk(tau.data() + k * kIiwaNv, kIiwaNv);
    ASSERT_TRUE(evaluate_outputs<double>(model, ws, qk, qdk, tauk, InputKind::kTau, rbdgrad::kAllOutputs).is_ok());
    for (int i = 0; i < kIiwaNv; ++i) {
      const std::size_t v = k * kIiwaNv + i;
      ASSERT_EQ(bits(qdd[v]), bits(ws.qdd[i])) << "qdd state " << k << " element " << i;
      ASSERT_EQ(bits(tau_out[v]), bits(ws.tau[i])) << "tau state " << k << " element " << i;
      for (int j = 0; j < kIiwaNv; ++j) {
        // row-major on the wire
        const std::size_t e = (k * kIiwaNv + i) * kIiwaNv + j;
        ASSERT_EQ(bits(minv[e]), bits(ws.Minv(i, j))) << "minv state " << k;
        ASSERT_EQ(bits(dqdd_dq[e]), bits(ws.dqdd_dq(i, j))) << "dqdd_dq state " << k;
        ASSERT_EQ(bits(dqdd_dqd[e]), bits(ws.dqdd_dqd(i, j))) << "dqdd_dqd state " << k;
        ASSERT_EQ(bits(dtau_dq[e]), bits(ws.dtau_dq(i, j))) << "dtau_dq state " << k;
        ASSERT_EQ(bits(dtau_dqd[e]), bits(ws.dtau_dqd(i, j))) << "dtau_dqd state " << k;
        ASSERT_EQ(bits(m[e]), bits(ws.M(i, j))) << "m state " << k;
      }
    }
  }
}

TEST_F(DaemonTest, HintedCudaBackendComputesInF32) {
  v1::ComputeRequest req = make_request("panda", kPandaNv, 3, 2, "gpu", kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  req.set_precision(v1::PRECISION_F32);
  v1::ComputeResponse resp;
  ASSERT_TRUE(compute(req, &resp).ok());
  EXPECT_EQ(resp.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(resp.precision(), v1::PRECISION_F32);
  // the fake writes k + e / 1000 for element e of state k, in float
  const std::vector<double> dtau_dq = values_of(resp.dtau_dq());
  ASSERT_EQ(dtau_dq.size(), 3u * kPandaNv * kPandaNv);
  EXPECT_EQ(dtau_dq[2 * kPandaNv * kPandaNv + 5], static_cast<double>(2.0f + 5.0f / 1000.0f));
  EXPECT_FALSE(resp.has_m());
}

TEST_F(DaemonTest, StreamAnswersEveryRequestInOrder) {
  auto stub = v1::Dynamics::NewStub(channel_);
  grpc::ClientContext ctx;
  auto stream = stub->ComputeStream(&ctx);
  constexpr int kRequests = 20;
  // all written before any is read: the server reads ahead and still answers in order
  for (int i = 0; i < kRequests; ++i) {
    const uint32_t n = 1 + i % 5;
    const int nv = i % 2 ? kPandaNv : kIiwaNv;
    const std::string id = std::to_string(i);  // (not "s" + ...: a GCC 12 -Wrestrict false positive)
    ASSERT_TRUE(stream->Write(make_request(i % 2 ? "panda" : "iiwa14", nv, n, 100 + i, id)));
  }
  stream->WritesDone();
  v1::ComputeResponse resp;
  for (int i = 0; i < kRequests; ++i) {
    ASSERT_TRUE(stream->Read(&resp)) << "response " << i;
    EXPECT_EQ(resp.request_id(), std::to_string(i));
    EXPECT_EQ(resp.num_states(), static_cast<uint32_t>(1 + i % 5));
    const std::size_t nv = i % 2 ? kPandaNv : kIiwaNv;
    EXPECT_EQ(resp.qdd().data().size(), resp.num_states() * nv * sizeof(double));
  }
  EXPECT_FALSE(stream->Read(&resp));
  const grpc::Status s = stream->Finish();
  EXPECT_TRUE(s.ok()) << s.error_message();
}

TEST_F(DaemonTest, ABadRequestFinishesTheStreamNamingIt) {
  auto stub = v1::Dynamics::NewStub(channel_);
  grpc::ClientContext ctx;
  auto stream = stub->ComputeStream(&ctx);
  ASSERT_TRUE(stream->Write(make_request("iiwa14", kIiwaNv, 2, 1, "good")));
  v1::ComputeResponse resp;
  ASSERT_TRUE(stream->Read(&resp));
  EXPECT_EQ(resp.request_id(), "good");
  v1::ComputeRequest bad = make_request("iiwa14", kIiwaNv, 4, 2, "bad");
  set_value(bad.mutable_qd(), 3 * kIiwaNv + 2, std::numeric_limits<double>::quiet_NaN());
  stream->Write(bad);
  stream->Write(make_request("iiwa14", kIiwaNv, 2, 3, "after"));  // not answered
  EXPECT_FALSE(stream->Read(&resp));
  const grpc::Status s = stream->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(), "request 'bad': state 3: field 'qd' element 2 is not finite (nan)");
  expect_still_serving();
}

TEST_F(DaemonTest, AStreamErrorComesAfterTheResponsesBeforeIt) {
  auto stub = v1::Dynamics::NewStub(channel_);
  grpc::ClientContext ctx;
  auto stream = stub->ComputeStream(&ctx);
  // the second request is refused at once, while the first still computes: the first is answered
  ASSERT_TRUE(stream->Write(slow_request("slow")));
  ASSERT_TRUE(stream->Write(make_request("nope", kIiwaNv, 1, 1, "unknown")));
  stream->WritesDone();
  v1::ComputeResponse resp;
  ASSERT_TRUE(stream->Read(&resp));
  EXPECT_EQ(resp.request_id(), "slow");
  EXPECT_FALSE(stream->Read(&resp));
  const grpc::Status s = stream->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(s.error_message(), "request 'unknown': model 'nope' is not loaded (loaded models: iiwa14, panda)");
}

TEST_F(DaemonTest, AStreamRequestWithoutIdIsNamedByItsPosition) {
  auto stub = v1::Dynamics::NewStub(channel_);
  grpc::ClientContext ctx;
  auto stream = stub->ComputeStream(&ctx);
  ASSERT_TRUE(stream->Write(make_request("iiwa14", kIiwaNv, 1, 1, "")));
  ASSERT_TRUE(stream->Write(make_request("nope", kIiwaNv, 1, 1, "")));
  stream->WritesDone();
  v1::ComputeResponse resp;
  EXPECT_TRUE(stream->Read(&resp));
  EXPECT_FALSE(stream->Read(&resp));
  const grpc::Status s = stream->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(s.error_message(), "stream message 1: model 'nope' is not loaded (loaded models: iiwa14, panda)");
}

TEST_F(DaemonTest, ConcurrentUnaryAndStreamedRequestsAreAllAnsweredCorrectly) {
  // the answer to each request kind, computed alone first
  const uint32_t sizes[] = {1, 8, 64};
  std::map<uint32_t, std::string> expected;
  for (uint32_t n : sizes) {
    v1::ComputeResponse resp;
    ASSERT_TRUE(compute(make_request("iiwa14", kIiwaNv, n, n, "ref"), &resp).ok());
    expected[n] = resp.dtau_dq().data();
  }
  constexpr int kThreads = 8, kPerThread = 30;
  std::atomic<int> correct{0};
  std::vector<std::thread> clients;
  for (int t = 0; t < kThreads; ++t) {
    clients.emplace_back([&, t] {
      auto stub = v1::Dynamics::NewStub(channel_);
      if (t % 2 == 0) {
        for (int i = 0; i < kPerThread; ++i) {
          const uint32_t n = sizes[(t + i) % 3];
          grpc::ClientContext ctx;
          v1::ComputeResponse resp;
          const std::string id = std::to_string(t * 1000 + i);
          if (stub->Compute(&ctx, make_request("iiwa14", kIiwaNv, n, n, id), &resp).ok() &&
              resp.request_id() == id && resp.dtau_dq().data() == expected[n]) {
            ++correct;
          }
        }
        return;
      }
      // an MPC-like stream: one request per step, each answered before the next
      grpc::ClientContext ctx;
      auto stream = stub->ComputeStream(&ctx);
      for (int i = 0; i < kPerThread; ++i) {
        const uint32_t n = sizes[(t + i) % 3];
        const std::string id = std::to_string(t * 1000 + i);
        v1::ComputeResponse resp;
        if (stream->Write(make_request("iiwa14", kIiwaNv, n, n, id)) && stream->Read(&resp) &&
            resp.request_id() == id && resp.dtau_dq().data() == expected[n]) {
          ++correct;
        }
      }
      stream->WritesDone();
      EXPECT_TRUE(stream->Finish().ok());
    });
  }
  for (std::thread& c : clients) c.join();
  EXPECT_EQ(correct.load(), kThreads * kPerThread);
  EXPECT_TRUE(wait_for_in_flight(*daemon_, 0));
}

TEST_F(DaemonTest, ListsModelsAndDescribesOne) {
  auto stub = v1::Dynamics::NewStub(channel_);
  {
    grpc::ClientContext ctx;
    v1::ListModelsResponse resp;
    ASSERT_TRUE(stub->ListModels(&ctx, v1::ListModelsRequest(), &resp).ok());
    ASSERT_EQ(resp.models_size(), 2);
    EXPECT_EQ(resp.models(0).name(), "iiwa14");
    EXPECT_EQ(resp.models(0).nv(), 7u);
    EXPECT_EQ(resp.models(0).source(), "<embedded>");
    EXPECT_EQ(resp.models(1).name(), "panda");
  }
  {
    grpc::ClientContext ctx;
    v1::GetModelRequest req;
    req.set_name("panda");
    v1::GetModelResponse resp;
    ASSERT_TRUE(stub->GetModel(&ctx, req, &resp).ok());
    const Model& model = daemon_->models().find("panda")->model;
    EXPECT_EQ(resp.name(), "panda");
    EXPECT_EQ(resp.nv(), static_cast<uint32_t>(kPandaNv));
    ASSERT_EQ(resp.joints_size(), kPandaNv);
    for (int i = 0; i < kPandaNv; ++i) {
      const JointInfo& j = model.joints[i];
      EXPECT_EQ(resp.joints(i).name(), j.name);
      EXPECT_EQ(resp.joints(i).type(), j.urdf_type);
      EXPECT_EQ(resp.joints(i).parent(), model.parent[i]);
      EXPECT_EQ(resp.joints(i).child_link(), j.child_link);
      EXPECT_EQ(resp.joints(i).parent_link(), j.parent_link);
      EXPECT_EQ(resp.joints(i).lower_limit(), j.lower_limit);
      EXPECT_EQ(resp.joints(i).upper_limit(), j.upper_limit);
      EXPECT_EQ(resp.joints(i).effort_limit(), j.effort_limit);
      EXPECT_EQ(resp.joints(i).velocity_limit(), j.velocity_limit);
    }
    // in model order: the arm's chain first
    EXPECT_EQ(resp.joints(0).name(), "panda_joint1");
    EXPECT_EQ(resp.joints(0).parent(), -1);
    EXPECT_EQ(resp.joints(6).name(), "panda_joint7");
    EXPECT_EQ(resp.joints(6).parent(), 5);
    EXPECT_LT(resp.joints(0).lower_limit(), resp.joints(0).upper_limit());
    ASSERT_EQ(resp.gravity_size(), 3);
    EXPECT_EQ(resp.gravity(2), -9.8);  // the configured gravity
    EXPECT_THAT(resp.summary(), StartsWith("model 'panda'"));
  }
  {
    grpc::ClientContext ctx;
    v1::GetModelRequest req;
    req.set_name("atlas");
    v1::GetModelResponse resp;
    const grpc::Status s = stub->GetModel(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_EQ(s.error_message(), "model 'atlas' is not loaded (loaded models: iiwa14, panda)");
  }
}

TEST_F(DaemonTest, ServerInfoListsBackendsReadyOrNotAndTheLimits) {
  auto stub = v1::Dynamics::NewStub(channel_);
  grpc::ClientContext ctx;
  v1::GetServerInfoResponse resp;
  ASSERT_TRUE(stub->GetServerInfo(&ctx, v1::GetServerInfoRequest(), &resp).ok());
  EXPECT_EQ(resp.version(), RBDGRAD_VERSION_FOR_TESTS);
  EXPECT_EQ(resp.max_states_per_request(), 1000u);
  EXPECT_EQ(resp.max_concurrent_requests(), 256u);
  // derived: 1000 states of panda (the larger model), every output in f64, and the margin
  EXPECT_EQ(resp.max_message_bytes(), largest_compute_message_bytes(1000, kPandaNv));
  std::map<std::string, v1::BackendInfo> backends;
  for (const v1::BackendInfo& b : resp.backends()) backends[b.name()] = b;
  ASSERT_EQ(backends.size(), 3u);
  EXPECT_TRUE(backends["cpu"].ready());
  EXPECT_EQ(backends["cpu"].backend(), v1::BACKEND_CPU);
  EXPECT_EQ(backends["cpu"].precisions_size(), 3);
  EXPECT_TRUE(backends["cuda"].ready());
  ASSERT_EQ(backends["cuda"].precisions_size(), 2);
  EXPECT_EQ(backends["cuda"].precisions(1), v1::PRECISION_F32);
  EXPECT_FALSE(backends["fpga"].ready());
  EXPECT_EQ(backends["fpga"].reason(), "not configured");
}

TEST_F(DaemonTest, HealthServiceSaysServing) {
  std::string response;
  // grpc.health.v1.HealthCheckRequest{service: ""} is empty; the response {status: SERVING} is 08 01
  const grpc::Status s = generic_unary(channel_, "/grpc.health.v1.Health/Check", "", &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(response, std::string("\x08\x01", 2));
}

TEST_F(DaemonTest, ReflectionListsTheDynamicsService) {
  grpc::GenericStub stub(channel_);
  grpc::CompletionQueue cq;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  auto call = stub.PrepareCall(&ctx, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  void* tag = nullptr;
  bool ok = false;
  const auto step = [&](intptr_t expected) {
    ASSERT_TRUE(cq.Next(&tag, &ok));
    EXPECT_EQ(reinterpret_cast<intptr_t>(tag), expected);
    EXPECT_TRUE(ok);
  };
  call->StartCall(reinterpret_cast<void*>(1));
  step(1);
  // ServerReflectionRequest{list_services: ""}: field 7, length-delimited, empty
  call->Write(buffer_of(std::string("\x3a\x00", 2)), reinterpret_cast<void*>(2));
  step(2);
  call->WritesDone(reinterpret_cast<void*>(3));
  step(3);
  grpc::ByteBuffer response;
  call->Read(&response, reinterpret_cast<void*>(4));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  step(5);
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_THAT(string_of(response), HasSubstr("rbdgrad.v1.Dynamics"));
  EXPECT_THAT(string_of(response), HasSubstr("grpc.health.v1.Health"));
}

// --- every bad input of the issue: the right status, a message naming state and field, and the
// daemon still serving afterwards ---

TEST_F(DaemonTest, RefusesAnUnknownModel) {
  expect_refused(make_request("atlas", kIiwaNv, 2, 1, "m"), grpc::StatusCode::NOT_FOUND,
                 "request 'm': model 'atlas' is not loaded (loaded models: iiwa14, panda)");
}

TEST_F(DaemonTest, RefusesWrongArrayLengths) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 4, 1, "len");
  req.mutable_q()->mutable_data()->resize((4 * kIiwaNv - 1) * sizeof(double));
  expect_refused(req, grpc::StatusCode::INVALID_ARGUMENT,
                 "request 'len': field 'q' has 27 values, expected 28 (num_states 4 x nv 7)");
}

TEST_F(DaemonTest, RefusesNanAndInfNamingStateAndField) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 5, 1, "nan");
  set_value(req.mutable_qd(), 3 * kIiwaNv + 2, std::numeric_limits<double>::quiet_NaN());
  expect_refused(req, grpc::StatusCode::INVALID_ARGUMENT,
                 "request 'nan': state 3: field 'qd' element 2 is not finite (nan)");
  req = make_request("iiwa14", kIiwaNv, 5, 1, "inf");
  set_value(req.mutable_u(), 4 * kIiwaNv + 6, -std::numeric_limits<double>::infinity());
  expect_refused(req, grpc::StatusCode::INVALID_ARGUMENT,
                 "request 'inf': state 4: field 'tau' element 6 is not finite (-inf)");
}

TEST_F(DaemonTest, RefusesZeroStatesAndMoreThanTheLimit) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 1, 1, "zero");
  req.set_num_states(0);
  expect_refused(req, grpc::StatusCode::INVALID_ARGUMENT, "request 'zero': num_states is 0");
  expect_refused(make_request("iiwa14", kIiwaNv, 1001, 1, "big"), grpc::StatusCode::INVALID_ARGUMENT,
                 "request 'big': num_states 1001 exceeds the limit max_states_per_request = 1000");
}

TEST_F(DaemonTest, RefusesAPrecisionTheHintedBackendLacksAndAMissingBackend) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 2, 1, "fx", kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  req.set_precision(v1::PRECISION_FIXED);
  expect_refused(req, grpc::StatusCode::INVALID_ARGUMENT,
                 "request 'fx': backend cuda does not support precision fixed (it supports f64, f32)");
  req.set_backend(v1::BACKEND_FPGA);
  expect_refused(req, grpc::StatusCode::UNAVAILABLE, "request 'fx': backend fpga is not available: not configured");
  // what the backend's can_run refuses: the fake cuda has no M output
  req = make_request("iiwa14", kIiwaNv, 2, 1, "m-out", {v1::OUTPUT_M});
  req.set_backend(v1::BACKEND_CUDA);
  expect_refused(req, grpc::StatusCode::UNIMPLEMENTED, "request 'm-out': cuda: output M is not supported");
}

TEST_F(DaemonTest, RefusesAMalformedMessage) {
  // field 1 (model) announced with 2^35 bytes that never come: no protobuf parser accepts it
  const std::string garbage("\x0a\xff\xff\xff\xff\x7f\x01\x02\x03", 9);
  const grpc::Status s = generic_unary(channel_, "/rbdgrad.v1.Dynamics/Compute", garbage, nullptr);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(),
            "malformed ComputeRequest (9 bytes): not a valid protobuf encoding of rbdgrad.v1.ComputeRequest");
  expect_still_serving();
}

// The bytes of state k of an output tensor (nv or nv x nv doubles per state).
std::string state_bytes(const v1::Tensor& t, std::size_t k, std::size_t per_state) {
  return t.data().substr(k * per_state * sizeof(double), per_state * sizeof(double));
}

TEST_F(DaemonTest, FixedPointStatesThatLeaveTheRangeAreComputedAgainInFloatingPoint) {
  // Q16.16 on the CPU: state 1 spins fast enough to overflow the format; the default
  // fixed_point_fallback (cpu) computes it again, in f64
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 3, 1, "ovf");
  req.set_precision(v1::PRECISION_FIXED);
  for (int i = 0; i < kIiwaNv; ++i) set_value(req.mutable_qd(), 1 * kIiwaNv + i, 200.0);
  v1::ComputeResponse resp;
  grpc::Status s = compute(req, &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(resp.precision(), v1::PRECISION_FIXED);
  ASSERT_EQ(resp.fallback_states_size(), 1);
  EXPECT_EQ(resp.fallback_states(0), 1u);
  EXPECT_EQ(resp.fallback_backend(), v1::BACKEND_CPU);
  EXPECT_EQ(resp.fallback_precision(), v1::PRECISION_F64);

  // state 1 is the f64 result, states 0 and 2 the fixed-point ones
  v1::ComputeRequest f64 = req;
  f64.set_precision(v1::PRECISION_F64);
  v1::ComputeResponse resp64;
  ASSERT_TRUE(compute(f64, &resp64).ok());
  v1::ComputeRequest calm = req;  // state 1 back in range: no fallback
  for (int i = 0; i < kIiwaNv; ++i) set_value(calm.mutable_qd(), 1 * kIiwaNv + i, 0.5);
  v1::ComputeResponse resp_fixed;
  ASSERT_TRUE(compute(calm, &resp_fixed).ok());
  EXPECT_EQ(resp_fixed.fallback_states_size(), 0);
  for (v1::Output o : kAllOutputs) {
    const std::size_t per = is_matrix_output(o) ? kIiwaNv * kIiwaNv : kIiwaNv;
    const v1::Tensor& got = *response_tensor(resp, o);
    EXPECT_EQ(state_bytes(got, 1, per), state_bytes(*response_tensor(resp64, o), 1, per)) << o;
    for (std::size_t k : {0, 2})
      EXPECT_EQ(state_bytes(got, k, per), state_bytes(*response_tensor(resp_fixed, o), k, per)) << o;
  }
}

TEST(DaemonFallback, WithoutAFallbackAnOutOfRangeStateFailsTheRequestNamingIt) {
  DaemonOptions options = test_options("");
  options.config.fixed_point_fallback = "";
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 3, 1, "ovf");
  req.set_precision(v1::PRECISION_FIXED);
  for (int i = 0; i < kIiwaNv; ++i) set_value(req.mutable_qd(), 1 * kIiwaNv + i, 200.0);
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const grpc::Status s = stub->Compute(&ctx, req, &resp);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_THAT(s.error_message(), StartsWith("request 'ovf': cpu: state 1: "));
  EXPECT_THAT(s.error_message(), HasSubstr("fixed-point overflow"));
}

TEST_F(DaemonTest, APerStateNumericalFailureFailsTheRequestNamingTheState) {
  // the plugin's own codes pass through: NUMERICAL -> OUT_OF_RANGE, UNAVAILABLE -> UNAVAILABLE
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 4, 1, "num", kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  set_value(req.mutable_u(), 2 * kIiwaNv, 777.0);
  expect_refused(req, grpc::StatusCode::OUT_OF_RANGE, "request 'num': cuda: state 2: scripted numerical failure");
  req = make_request("iiwa14", kIiwaNv, 1, 1, "lost", kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  set_value(req.mutable_q(), 0, -999.0);
  expect_refused(req, grpc::StatusCode::UNAVAILABLE, "request 'lost': cuda: device lost");
}

}  // namespace
}  // namespace rbdgrad::server

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
namespace v1 = rbdgrad::v1;

// A model configured with locked joints is served reduced: GetModel lists the kept joints, and a
// request computes exactly what the core library computes on lock_joints' model.
TEST(DaemonModels, LockedJointsServeTheReducedModel) {
  DaemonOptions options = test_options("");
  ModelConfig wristless{"wristless", "", "iiwa14", std::nullopt};
  wristless.locked_joints = {{"iiwa_joint_6", 0.5}, {"iiwa_joint_7", -1.0}};
  options.config.models = {wristless};
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  {
    grpc::ClientContext ctx;
    v1::GetModelRequest req;
    req.set_name("wristless");
    v1::GetModelResponse resp;
    ASSERT_TRUE(stub->GetModel(&ctx, req, &resp).ok());
    EXPECT_EQ(resp.nv(), 5u);
    ASSERT_EQ(resp.joints_size(), 5);
    EXPECT_EQ(resp.joints(4).name(), "iiwa_joint_5");
  }
  constexpr int kNv = 5;
  constexpr uint32_t kN = 4;
  const v1::ComputeRequest req = make_request("wristless", kNv, kN, 3, "locked", {v1::OUTPUT_DQDD_DQ});
  v1::ComputeResponse resp;
  grpc::ClientContext ctx;
  ASSERT_TRUE(stub->Compute(&ctx, req, &resp).ok());
  Model full, reduced;
  ASSERT_TRUE(cli::load_model("iiwa14", std::nullopt, full).is_ok());
  ASSERT_TRUE(lock_joints(full, {{"iiwa_joint_6", 0.5}, {"iiwa_joint_7", -1.0}}, reduced).is_ok());
  Workspace ws(reduced);
  const std::vector<double> q = values_of(req.q()), qd = values_of(req.qd()), tau = values_of(req.u());
  const std::vector<double> dq = values_of(resp.dqdd_dq());
  ASSERT_EQ(dq.size(), std::size_t{kN} * kNv * kNv);
  for (uint32_t k = 0; k < kN; ++k) {
    const Eigen::Map<const Eigen::VectorXd> qk(q.data() + k * kNv, kNv), qdk(qd.data() + k * kNv, kNv),
        tauk(tau.data() + k * kNv, kNv);
    ASSERT_TRUE(evaluate_outputs<double>(reduced, ws, qk, qdk, tauk, InputKind::kTau, kOutputDqddDq).is_ok());
    for (int i = 0; i < kNv; ++i)
      for (int j = 0; j < kNv; ++j)
        ASSERT_EQ(dq[(k * kNv + i) * kNv + j], ws.dqdd_dq(i, j)) << "state " << k << " (" << i << ", " << j << ")";
  }
}

}  // namespace
}  // namespace rbdgrad::server
