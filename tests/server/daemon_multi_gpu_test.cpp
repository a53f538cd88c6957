// One daemon, several GPUs: the fake cuda plugin (fakes/fake_cuda.cpp) loaded twice, as cuda0 and
// cuda1 (the plugins entries' `name`), next to the CPU backend. Both serve; a BACKEND_CUDA hint
// means either (the one predicted to finish first, here the idle one); responses, server info,
// metrics and the latency models name each; the same name twice is refused, saying to set `name:`.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "daemon_test_support.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;

DaemonOptions two_gpu_options() {
  DaemonOptions options = test_options("");
  PluginConfig gpu0{FAKE_CUDA_PATH, {{"device", "0"}}};
  gpu0.name = "cuda0";
  PluginConfig gpu1{FAKE_CUDA_PATH, {{"device", "1"}}};
  gpu1.name = "cuda1";
  options.config.plugins = {gpu0, gpu1};
  return options;
}

v1::ComputeResponse compute_cuda(const std::shared_ptr<grpc::Channel>& channel, const std::string& id,
                                 grpc::Status* status = nullptr) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 3, 7, id, kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::ComputeResponse resp;
  const grpc::Status s = stub->Compute(&ctx, req, &resp);
  if (status != nullptr) *status = s;
  EXPECT_TRUE(s.ok()) << s.error_message();
  return resp;
}

TEST(DaemonMultiGpu, OneLibraryServesAsTwoBackends) {
  DaemonOptions options = two_gpu_options();
  options.config.metrics_listen = "";
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  std::map<std::string, const BackendState*> states;
  for (const BackendState& b : daemon->backends().backends()) states[b.name] = &b;
  ASSERT_EQ(states.count("cuda0"), 1u);
  ASSERT_EQ(states.count("cuda1"), 1u);
  EXPECT_TRUE(states["cuda0"]->ready) << states["cuda0"]->reason;
  EXPECT_TRUE(states["cuda1"]->ready) << states["cuda1"]->reason;
  EXPECT_EQ(states["cuda0"]->kind, "cuda");
  EXPECT_EQ(states["cuda1"]->kind, "cuda");
  EXPECT_EQ(states["cuda1"]->options, "device=1");
  EXPECT_EQ(states.count("cuda"), 0u) << "no third backend under the plugin's own name";
  const auto channel = channel_to(daemon->addresses()[0]);

  // idle: the first of the kind
  v1::ComputeResponse r = compute_cuda(channel, "first");
  EXPECT_EQ(r.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(r.backend_name(), "cuda0");
  EXPECT_EQ(values_of(r.dqdd_dq()).size(), 3u * kIiwaNv * kIiwaNv);

  // cuda0 busy for 300 ms: a BACKEND_CUDA hint goes to cuda1
  grpc::Status slow_status;
  v1::ComputeResponse slow_response;
  std::thread slow([&] {
    auto stub = v1::Dynamics::NewStub(channel);
    grpc::ClientContext ctx;
    slow_status = stub->Compute(&ctx, slow_request("slow"), &slow_response);
  });
  for (int i = 0; i < 400; ++i) {
    const InstancePool* pool = daemon->backends().pool("cuda0", *daemon->models().find("iiwa14"));
    ASSERT_NE(pool, nullptr);
    if (pool->load().running == 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r = compute_cuda(channel, "second");
  EXPECT_EQ(r.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(r.backend_name(), "cuda1") << "cuda0 is busy";
  slow.join();
  ASSERT_TRUE(slow_status.ok()) << slow_status.error_message();
  EXPECT_EQ(slow_response.backend_name(), "cuda0");

  // automatic routing without latency models stays on the cpu
  {
    v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 2, 1, "auto", kCudaOutputs);
    auto stub = v1::Dynamics::NewStub(channel);
    grpc::ClientContext ctx;
    v1::ComputeResponse resp;
    ASSERT_TRUE(stub->Compute(&ctx, req, &resp).ok());
    EXPECT_EQ(resp.backend(), v1::BACKEND_CPU);
    EXPECT_EQ(resp.backend_name(), "cpu");
  }

  // server info: a row each, of kind cuda; no "cuda: not configured" row
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  v1::GetServerInfoResponse info;
  ASSERT_TRUE(stub->GetServerInfo(&ctx, v1::GetServerInfoRequest(), &info).ok());
  std::map<std::string, v1::BackendInfo> rows;
  for (const v1::BackendInfo& b : info.backends()) rows[b.name()] = b;
  ASSERT_EQ(rows.count("cuda0"), 1u);
  ASSERT_EQ(rows.count("cuda1"), 1u);
  EXPECT_EQ(rows.count("cuda"), 0u);
  EXPECT_EQ(rows["cuda0"].backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(rows["cuda1"].backend(), v1::BACKEND_CUDA);
  EXPECT_TRUE(rows["cuda1"].ready());
  EXPECT_EQ(rows["cuda1"].queues_size(), 2) << "iiwa14 and panda";
  EXPECT_EQ(rows["fpga"].reason(), "not configured");

  // metrics: each by its name
  for (int i = 0; i < 400 && daemon->service().in_flight() != 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const std::string text = daemon->metrics().text();
  EXPECT_THAT(text, HasSubstr("rbdgrad_requests_total{backend=\"cuda0\",code=\"ok\",mode=\"none\",model=\"iiwa14\","
                              "precision=\"f64\"} 2"));
  EXPECT_THAT(text, HasSubstr("rbdgrad_requests_total{backend=\"cuda1\",code=\"ok\",mode=\"none\",model=\"iiwa14\","
                              "precision=\"f64\"} 1"));
  EXPECT_THAT(text, HasSubstr("rbdgrad_queue_requests{backend=\"cuda1\",model=\"iiwa14\",state=\"queued\"} 0"));
}

// Each backend of the kind is timed and keeps its own latency models; the cost policy and a
// BACKEND_CUDA hint choose between them by prediction.
TEST(DaemonMultiGpu, EachBackendHasItsOwnLatencyModels) {
  DaemonOptions options = two_gpu_options();
  options.config.models = {{"iiwa14", "", "iiwa14", std::nullopt}};
  options.config.scheduler.calibrate = "start";
  options.config.scheduler.calibration_sizes = {1, 16};
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const CalibrationTable table = daemon->scheduler().table();
  EXPECT_NE(table.find("cuda0", "iiwa14", RBDGRAD_PRECISION_F64), nullptr);
  EXPECT_NE(table.find("cuda1", "iiwa14", RBDGRAD_PRECISION_F64), nullptr);
  EXPECT_NE(table.find("cuda1", "iiwa14", RBDGRAD_PRECISION_F32), nullptr);
  EXPECT_EQ(table.find("cuda", "iiwa14", RBDGRAD_PRECISION_F64), nullptr);
  // calibration keys differ by name and device (the options)
  std::map<std::string, const BackendState*> states;
  for (const BackendState& b : daemon->backends().backends()) states[b.name] = &b;
  EXPECT_NE(backend_fingerprint(*states["cuda0"]), backend_fingerprint(*states["cuda1"]));

  const auto channel = channel_to(daemon->addresses()[0]);
  std::set<std::string> served;
  for (int i = 0; i < 4; ++i) served.insert(compute_cuda(channel, "c" + std::to_string(i)).backend_name());
  for (const std::string& name : served) EXPECT_TRUE(name == "cuda0" || name == "cuda1") << name;
}

// A BACKEND_CUDA request whose call on cuda0 runs past scheduler.backend_timeout_ms runs again on
// cuda1, the other backend of its kind (never on the cpu: the hint names the kind). The fake holds
// the marked request 300 ms on each, past the 100 ms limit: cuda1 times out as well, and with no
// backend of the kind left, its call is waited for and answers.
TEST(DaemonMultiGpu, AHintedRequestTimedOutOnOneGpuRunsOnTheOther) {
  DaemonOptions options = two_gpu_options();
  options.config.scheduler.backend_timeout_ms = 100;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const grpc::Status s = stub->Compute(&ctx, slow_request("slow"), &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(resp.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(resp.backend_name(), "cuda1");
  ASSERT_EQ(resp.failovers_size(), 1);
  EXPECT_THAT(resp.failovers(0), ::testing::StartsWith("cuda0: timed out: still running after "));
  const std::string text = daemon->metrics().text();
  EXPECT_THAT(text, HasSubstr("rbdgrad_backend_timeouts_total{backend=\"cuda0\"} 1"));
  EXPECT_THAT(text, HasSubstr("rbdgrad_backend_timeouts_total{backend=\"cuda1\"} 1"));
  // cuda1's call succeeded in the end; cuda0's late one too (the daemon waits for it as it stops)
  for (const BackendState& b : daemon->backends().backends()) {
    if (b.name == "cuda1") {
      EXPECT_FALSE(daemon->scheduler().suspect(b));
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  daemon.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(3));
}

TEST(DaemonMultiGpu, TheSameNameTwiceIsRefusedSayingToSetName) {
  DaemonOptions options = two_gpu_options();
  options.config.plugins[1].name = "cuda0";
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr) << "the daemon serves with what loaded";
  const BackendState* refused = nullptr;
  int named_cuda0 = 0;
  for (const BackendState& b : daemon->backends().backends()) {
    if (b.name != "cuda0") continue;
    ++named_cuda0;
    if (!b.ready) refused = &b;
  }
  EXPECT_EQ(named_cuda0, 2);
  ASSERT_NE(refused, nullptr);
  EXPECT_THAT(refused->reason, HasSubstr("name 'cuda0' is already taken"));
  EXPECT_THAT(refused->reason, HasSubstr("its own `name:`"));

  // without names: the second entry of the library is refused the same way
  DaemonOptions unnamed = test_options("");
  unnamed.config.plugins = {{FAKE_CUDA_PATH, {{"device", "0"}}}, {FAKE_CUDA_PATH, {{"device", "1"}}}};
  daemon = start_daemon(std::move(unnamed));
  ASSERT_NE(daemon, nullptr);
  std::string reason;
  for (const BackendState& b : daemon->backends().backends())
    if (!b.ready) reason = b.reason;  // under its file's name, as a plugin that did not load
  EXPECT_THAT(reason, HasSubstr("name 'cuda' is already taken"));
  EXPECT_THAT(reason, HasSubstr("(e.g. cuda0, cuda1)"));
}

}  // namespace
}  // namespace rbdgrad::server
