// Tests for server/daemon.cpp: admission limits, graceful stop, start-up failures, each on a
// daemon of its own.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

#include "daemon_test_support.hpp"
#include "unix_socket.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;  // the shared helpers of daemon_test_support.hpp
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(DaemonLimits, RequestsBeyondMaxConcurrentAreResourceExhausted) {
  DaemonOptions options = test_options("");
  options.config.limits.max_concurrent_requests = 1;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));

  grpc::ClientContext slow_ctx;
  v1::ComputeResponse slow_resp;
  std::promise<grpc::Status> slow_done;
  const v1::ComputeRequest slow = slow_request("slow");
  stub->async()->Compute(&slow_ctx, &slow, &slow_resp, [&](grpc::Status s) { slow_done.set_value(std::move(s)); });
  ASSERT_TRUE(wait_for_in_flight(*daemon, 1));

  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const grpc::Status refused = stub->Compute(&ctx, make_request("iiwa14", kIiwaNv, 1, 1, "second"), &resp);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(refused.error_message(), "too many requests in flight (limit max_concurrent_requests = 1)");

  EXPECT_TRUE(slow_done.get_future().get().ok());
  ASSERT_TRUE(wait_for_in_flight(*daemon, 0));
  grpc::ClientContext again;
  EXPECT_TRUE(stub->Compute(&again, make_request("iiwa14", kIiwaNv, 1, 1, "third"), &resp).ok());
}

TEST(DaemonLimits, MessagesAboveMaxMessageBytesAreRefusedByGrpc) {
  DaemonOptions options = test_options("");
  options.config.limits.max_message_bytes = 4096;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  // 64 states of q, qd and tau: 10.8 kB
  const grpc::Status s = stub->Compute(&ctx, make_request("iiwa14", kIiwaNv, 64, 1, "large"), &resp);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  // a response above the limit is not sent either
  grpc::ClientContext small_ctx;
  const grpc::Status out = stub->Compute(&small_ctx, make_request("iiwa14", kIiwaNv, 8, 1, "small"), &resp);
  EXPECT_EQ(out.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << out.error_message();
}

TEST(DaemonStop, InFlightRequestsCompleteAndStreamsAreFinished) {
  std::unique_ptr<Daemon> daemon = start_daemon(test_options("stop.sock"));
  ASSERT_NE(daemon, nullptr);
  const std::string socket_path = daemon->addresses()[1].address;
  EXPECT_NE(socket_inode(socket_path), 0u);
  const auto channel = channel_to(daemon->addresses()[0]);
  auto stub = v1::Dynamics::NewStub(channel);

  // an open stream, idle between two control steps
  grpc::ClientContext stream_ctx;
  auto stream = stub->ComputeStream(&stream_ctx);
  ASSERT_TRUE(stream->Write(make_request("iiwa14", kIiwaNv, 1, 1, "step")));
  v1::ComputeResponse step;
  ASSERT_TRUE(stream->Read(&step));
  ASSERT_TRUE(wait_for_in_flight(*daemon, 0));  // the step's write is complete on the server too

  // a unary request computing while the daemon is asked to stop
  grpc::ClientContext slow_ctx;
  v1::ComputeResponse slow_resp;
  std::promise<grpc::Status> slow_done;
  const v1::ComputeRequest slow = slow_request("in-flight");
  stub->async()->Compute(&slow_ctx, &slow, &slow_resp, [&](grpc::Status s) { slow_done.set_value(std::move(s)); });
  ASSERT_TRUE(wait_for_in_flight(*daemon, 1));

  const auto t0 = Clock::now();
  daemon->stop();
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5));  // the idle stream did not hold it up

  const grpc::Status slow_status = slow_done.get_future().get();
  EXPECT_TRUE(slow_status.ok()) << slow_status.error_message();
  EXPECT_EQ(slow_resp.request_id(), "in-flight");
  EXPECT_EQ(slow_resp.num_states(), 2u);

  EXPECT_FALSE(stream->Read(&step));
  const grpc::Status stream_status = stream->Finish();
  EXPECT_EQ(stream_status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(stream_status.error_message(), "rbdgradd is shutting down");

  EXPECT_EQ(socket_inode(socket_path), 0u);  // our socket file is gone
  EXPECT_TRUE(daemon->addresses().empty());
  grpc::ClientContext late;
  late.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  v1::ComputeResponse resp;
  EXPECT_FALSE(stub->Compute(&late, make_request("iiwa14", kIiwaNv, 1, 1, "late"), &resp).ok());
  daemon->stop();  // idempotent
}

TEST(DaemonStop, IdleClientConnectionsDoNotHoldItUp) {
  // gRPC's own Shutdown waits, up to its deadline, for clients to close their connections; an
  // idle client never does. The grace (10 s) is for requests, not for idle connections.
  std::unique_ptr<Daemon> daemon = start_daemon(test_options("idle.sock"));
  ASSERT_NE(daemon, nullptr);
  std::vector<std::unique_ptr<v1::Dynamics::Stub>> stubs;
  for (const ListenAddress& address : daemon->addresses()) {
    stubs.push_back(v1::Dynamics::NewStub(channel_to(address)));
    grpc::ClientContext ctx;
    v1::ComputeResponse resp;
    ASSERT_TRUE(stubs.back()->Compute(&ctx, make_request("iiwa14", kIiwaNv, 1, 1, "connect"), &resp).ok())
        << address.text();
  }
  ASSERT_TRUE(wait_for_in_flight(*daemon, 0));
  const auto t0 = Clock::now();
  daemon->stop();
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(3));
}

TEST(ComputeContext, RefusesEverythingOnceShuttingDown) {
  const ModelRegistry models;
  std::unique_ptr<BackendPool> backends = BackendPool::create({}, models);
  LimitsConfig limits;
  limits.max_concurrent_requests = 1;
  const Scheduler scheduler(*backends, models, SchedulerConfig{});
  ComputeContext context(models, *backends, scheduler, limits);
  EXPECT_EQ(context.admit(), ComputeContext::Admission::kAdmitted);
  EXPECT_EQ(context.admit(), ComputeContext::Admission::kTooManyInFlight);
  EXPECT_EQ(context.in_flight(), 1);
  context.release();
  context.begin_shutdown();
  EXPECT_EQ(context.admit(), ComputeContext::Admission::kShuttingDown);
  EXPECT_EQ(context.in_flight(), 0);
}

TEST(DaemonCreate, FailsWithoutAnyBackendAndOnABadModel) {
  DaemonOptions options = test_options("");
  options.config.plugins.clear();
  options.cpu_plugin_path = "/nonexistent/librbdgrad_cpu.so";
  std::unique_ptr<Daemon> daemon;
  Status s = Daemon::create(options, daemon);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_EQ(daemon, nullptr);

  options = test_options("");
  options.config.models = {{"x", "", "no_such_robot", std::nullopt}};
  s = Daemon::create(options, daemon);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_THAT(s.message(), StartsWith("model 'x': "));
}

TEST(DaemonStart, RefusesNoAddressAndAPortInUse) {
  DaemonOptions options = test_options("");
  std::unique_ptr<Daemon> first = start_daemon(options);
  ASSERT_NE(first, nullptr);

  options.config.listen.tcp = first->addresses()[0].address;  // taken
  std::unique_ptr<Daemon> second;
  ASSERT_TRUE(Daemon::create(options, second).is_ok());
  EXPECT_EQ(second->start().code(), StatusCode::kFailedPrecondition);

  options.config.listen.tcp = "";
  ASSERT_TRUE(Daemon::create(options, second).is_ok());
  EXPECT_EQ(second->start().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace rbdgrad::server
