// The scheduler inside the daemon: requests without a backend hint routed by the cost policy over
// three fake backends of known latency (fakes/fake_timed.cpp: "fpga" 10 us + 10 us/state by its own
// model, "cpu" 300 us + 2 us/state and "cuda" 3000 us + 0.1 us/state, both timed at start-up),
// and GetServerInfo's latency models, queues and crossovers.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>

#include "daemon_test_support.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
namespace v1 = rbdgrad::v1;

DaemonOptions routing_options() {
  DaemonOptions options = test_options("");
  options.cpu_plugin_path = "";  // the fakes only
  ServerConfig& cfg = options.config;
  cfg.models = {{"iiwa14", "", "iiwa14", std::nullopt}};
  cfg.plugins = {{FAKE_TIMED_FPGA_PATH, {{"fixed_us", "10"}, {"per_state_us", "10"}}},
                 {FAKE_TIMED_CPU_PATH, {{"fixed_us", "300"}, {"per_state_us", "2"}}},
                 {FAKE_TIMED_CUDA_PATH, {{"fixed_us", "3000"}, {"per_state_us", "0.1"}}}};
  cfg.scheduler.calibrate = "start";
  cfg.scheduler.calibration_sizes = {1, 16, 256, 4096};
  return options;
}

v1::ComputeResponse compute_auto(const std::shared_ptr<grpc::Channel>& channel, std::uint32_t n,
                                 v1::Precision precision) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, n, n, "auto" + std::to_string(n), kCudaOutputs);
  req.set_precision(precision);
  req.set_backend(v1::BACKEND_AUTO);
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  v1::ComputeResponse resp;
  const grpc::Status s = stub->Compute(&ctx, req, &resp);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return resp;
}

TEST(DaemonRouting, CostPolicyOverThreeBackends) {
  std::unique_ptr<Daemon> daemon = start_daemon(routing_options());
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);

  v1::ComputeResponse r = compute_auto(channel, 1, v1::PRECISION_AUTO);
  EXPECT_EQ(r.backend(), v1::BACKEND_FPGA);
  EXPECT_EQ(r.precision(), v1::PRECISION_FIXED);
  r = compute_auto(channel, 200, v1::PRECISION_AUTO);
  EXPECT_EQ(r.backend(), v1::BACKEND_CPU);
  EXPECT_EQ(r.precision(), v1::PRECISION_F64);
  // a request for f64 never lands on the fixed-point backend
  r = compute_auto(channel, 1, v1::PRECISION_F64);
  EXPECT_EQ(r.backend(), v1::BACKEND_CPU);
  r = compute_auto(channel, 1000, v1::PRECISION_F32);  // within the daemon's 1000-state limit
  EXPECT_EQ(r.backend(), v1::BACKEND_CPU) << "cpu 2.3 ms against cuda 3.1 ms";

  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  v1::GetServerInfoResponse info;
  ASSERT_TRUE(stub->GetServerInfo(&ctx, v1::GetServerInfoRequest(), &info).ok());
  EXPECT_EQ(info.scheduler_policy(), "cost");
  std::map<std::string, v1::BackendInfo> backends;
  for (const v1::BackendInfo& b : info.backends()) backends[b.name()] = b;
  ASSERT_EQ(backends["fpga"].latency_models_size(), 1);
  const v1::LatencyModelInfo& fpga = backends["fpga"].latency_models(0);
  EXPECT_EQ(fpga.model(), "iiwa14");
  EXPECT_EQ(fpga.precision(), v1::PRECISION_FIXED);
  EXPECT_NEAR(fpga.fixed_us(), 20, 1e-9);  // one state: 10 + 10
  EXPECT_NEAR(fpga.per_state_us(), 10, 1e-9);
  EXPECT_EQ(fpga.n_size(), 4);
  EXPECT_EQ(backends["cpu"].latency_models_size(), 2);  // f64 and f32, measured
  EXPECT_THAT(backends["cpu"].latency_models(0).source(), ::testing::StartsWith("measured "));
  ASSERT_EQ(backends["cpu"].queues_size(), 1);
  EXPECT_EQ(backends["cpu"].queues(0).model(), "iiwa14");
  EXPECT_EQ(backends["cpu"].queues(0).queued(), 0u);
  ASSERT_EQ(info.routing_size(), 1);
  const v1::RoutingInfo& routing = info.routing(0);
  ASSERT_EQ(routing.crossovers_size(), 3);
  EXPECT_EQ(routing.crossovers(0).backend(), v1::BACKEND_FPGA);
  EXPECT_EQ(routing.crossovers(0).from_n(), 1u);
  EXPECT_EQ(routing.crossovers(1).backend_name(), "cpu");
  EXPECT_EQ(routing.crossovers(2).backend_name(), "cuda");
}

}  // namespace
}  // namespace rbdgrad::server
