// The scheduler inside the daemon: requests without a backend hint routed by the cost policy over
// three fake backends of known latency (fakes/fake_timed.cpp: "fpga" 10 us + 10 us/state by its own
// model, "cpu" 300 us + 2 us/state and "cuda" 3000 us + 0.1 us/state, both timed at start-up),
// and GetServerInfo's latency models, queues and crossovers.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <thread>

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
  // a margin of 2x: the latency models are timed sleeps, which a loaded machine stretches
  r = compute_auto(channel, 500, v1::PRECISION_F32);
  EXPECT_EQ(r.backend(), v1::BACKEND_CPU) << "cpu 1.3 ms against cuda 3.05 ms";

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

// Calibrate measures again on demand and answers with the new models and routing.
TEST(DaemonRouting, CalibrateOnDemand) {
  std::unique_ptr<Daemon> daemon = start_daemon(routing_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  const std::string before =
      daemon->scheduler().table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->source;
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // the source's clock has seconds
  grpc::ClientContext ctx;
  v1::CalibrateResponse resp;
  const grpc::Status s = stub->Calibrate(&ctx, v1::CalibrateRequest(), &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(resp.log_size(), 5);  // fpga fixed (its own model), cpu and cuda in f64 and f32
  EXPECT_THAT(resp.log(0), ::testing::HasSubstr("calibration: fpga iiwa14 fixed: "));
  ASSERT_EQ(resp.info().routing_size(), 1);
  EXPECT_EQ(resp.info().routing(0).crossovers_size(), 3);
  EXPECT_NE(daemon->scheduler().table().find("cpu", "iiwa14", RBDGRAD_PRECISION_F64)->source, before)
      << "measured again";
}

// A backend that fails a request as a whole hands it to the next best one; a pinned request
// fails with its backend.
TEST(DaemonRouting, FailoverToTheNextBestBackend) {
  DaemonOptions options = routing_options();
  options.config.plugins[0].options["fail_on_marker"] = "1";  // the fpga
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);
  auto stub = v1::Dynamics::NewStub(channel);

  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 1, 3, "lost", kCudaOutputs);
  set_value(req.mutable_q(), 0, -999.0);
  req.set_precision(v1::PRECISION_AUTO);
  {
    grpc::ClientContext ctx;
    v1::ComputeResponse resp;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(resp.backend(), v1::BACKEND_CPU) << "the next best after the fpga, for one state";
    EXPECT_EQ(resp.precision(), v1::PRECISION_F64) << "the cpu's best precision";
    ASSERT_EQ(resp.failovers_size(), 1);
    EXPECT_EQ(resp.failovers(0), "fpga: device lost");
    EXPECT_EQ(resp.request_id(), "lost");
  }
  {
    req.set_backend(v1::BACKEND_FPGA);  // pinned: no failover
    grpc::ClientContext ctx;
    v1::ComputeResponse resp;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE);
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("fpga: device lost"));
  }
  // and the daemon serves on
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_FPGA);
}

// A request whose predicted wait and compute time exceed its deadline fails at once.
TEST(DaemonRouting, RequestsThatCannotMeetTheirDeadlineFailFast) {
  DaemonOptions options = routing_options();
  options.config.scheduler.calibrate = "off";  // the fpga's own model is enough here
  options.config.plugins[0].options["fixed_us"] = "200000";  // 200 ms per request
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 1, 4, "hurry", kCudaOutputs);
  req.set_precision(v1::PRECISION_FIXED);
  req.set_backend(v1::BACKEND_FPGA);
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(100));
    v1::ComputeResponse resp;
    const auto t0 = std::chrono::steady_clock::now();
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("request 'hurry': cannot finish before its deadline"));
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("backend fpga predicts 200010 us"));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(100)) << "not refused at once";
  }
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    v1::ComputeResponse resp;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    EXPECT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(resp.backend(), v1::BACKEND_FPGA);
  }
}

// A backend that hangs: while its instance overruns its prediction, the cost policy routes around
// it, a request pinned to it with a short deadline is refused at once, one that was queued behind
// the hung call is refused when its deadline has passed (it never takes the backend's time), and
// the hung request itself is answered once the backend returns.
TEST(DaemonRouting, AHungBackendIsRoutedAroundAndDeadlinesHold) {
  DaemonOptions options = routing_options();
  options.config.plugins[0].options["hang_us"] = "1500000";  // the fpga hangs 1.5 s on the marker
  options.config.scheduler.backend_timeout_ms = 0;  // no bound: the call runs to its end (see below)
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);

  v1::ComputeRequest hang = make_request("iiwa14", kIiwaNv, 1, 5, "hang", kCudaOutputs);
  set_value(hang.mutable_q(), 0, -998.0);
  hang.set_precision(v1::PRECISION_AUTO);
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_FPGA) << "the fpga's 20 us wins";
  grpc::Status hung_status;
  v1::ComputeResponse hung_response;
  std::thread hung([&] {
    auto stub = v1::Dynamics::NewStub(channel);
    grpc::ClientContext ctx;
    hung_status = stub->Compute(&ctx, hang, &hung_response);
  });
  // queued behind it right away (the hang is not visible yet): admitted, then expired in the queue
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  v1::ComputeRequest queued = make_request("iiwa14", kIiwaNv, 1, 6, "queued", kCudaOutputs);
  queued.set_precision(v1::PRECISION_FIXED);
  queued.set_backend(v1::BACKEND_FPGA);
  grpc::Status queued_status;
  std::thread behind([&] {
    auto stub = v1::Dynamics::NewStub(channel);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(300));
    v1::ComputeResponse resp;
    queued_status = stub->Compute(&ctx, queued, &resp);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(400));

  // 0.4 s into a call predicted at 20 us: automatic requests go to the cpu
  const v1::ComputeResponse routed = compute_auto(channel, 1, v1::PRECISION_AUTO);
  EXPECT_EQ(routed.backend(), v1::BACKEND_CPU);
  {
    // pinned to the fpga with 200 ms left: refused now, naming the wait
    auto stub = v1::Dynamics::NewStub(channel);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    v1::ComputeRequest pinned = queued;
    pinned.set_request_id("pinned");
    v1::ComputeResponse resp;
    const auto t0 = std::chrono::steady_clock::now();
    const grpc::Status s = stub->Compute(&ctx, pinned, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("request 'pinned': cannot finish before its deadline"));
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("waiting for an instance"));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(100)) << "not refused at once";
  }
  hung.join();
  behind.join();
  EXPECT_TRUE(hung_status.ok()) << hung_status.error_message();
  EXPECT_EQ(hung_response.backend(), v1::BACKEND_FPGA);
  EXPECT_EQ(hung_response.request_id(), "hang");
  EXPECT_EQ(queued_status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  // the daemon's own refusal of the queued request (the client's deadline fired first; the
  // metrics show that the server answered it without computing it), right after the hung call
  const std::string refused = "rbdgrad_requests_total{backend=\"fpga\",code=\"deadline_exceeded\"";
  std::string text = daemon->metrics().text();
  for (int i = 0; i < 500 && text.find(refused) == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    text = daemon->metrics().text();
  }
  EXPECT_THAT(text, ::testing::HasSubstr(refused));
  // and the fpga serves again
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_FPGA);
}

// A bounded backend call (scheduler.backend_timeout_ms, issue 9): the fpga hangs 3 s on the
// marker; past the 300 ms limit the request runs again on the next best backend (the cpu), which
// answers it, the timeout is counted, the fpga is suspect and avoided, the late result is dropped
// when the fpga returns (which clears the suspicion), and the daemon stops cleanly afterwards.
TEST(DaemonRouting, AHungCallIsTimedOutAndItsRequestRunsElsewhere) {
  DaemonOptions options = routing_options();
  options.config.plugins[0].options["hang_us"] = "3000000";
  options.config.scheduler.backend_timeout_ms = 300;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_FPGA) << "the fpga's 20 us wins";

  v1::ComputeRequest hang = make_request("iiwa14", kIiwaNv, 1, 5, "hang", kCudaOutputs);
  set_value(hang.mutable_q(), 0, -998.0);
  hang.set_precision(v1::PRECISION_AUTO);
  auto stub = v1::Dynamics::NewStub(channel);
  const auto t0 = std::chrono::steady_clock::now();
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::ComputeResponse resp;
    const grpc::Status s = stub->Compute(&ctx, hang, &resp);
    const auto took = std::chrono::steady_clock::now() - t0;
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(resp.request_id(), "hang");
    EXPECT_EQ(resp.backend(), v1::BACKEND_CPU);
    EXPECT_EQ(resp.backend_name(), "cpu");
    EXPECT_EQ(resp.precision(), v1::PRECISION_F64) << "the cpu's best";
    ASSERT_EQ(resp.failovers_size(), 1);
    EXPECT_THAT(resp.failovers(0), ::testing::StartsWith("fpga: timed out: still running after "));
    EXPECT_THAT(resp.failovers(0), ::testing::HasSubstr("limit 300 ms"));
    // the cpu fake's outputs: element e of state 0 is e / 1000
    const std::vector<double> dq = values_of(resp.dqdd_dq());
    ASSERT_EQ(dq.size(), static_cast<std::size_t>(kIiwaNv * kIiwaNv));
    EXPECT_DOUBLE_EQ(dq[5], 0.005);
    EXPECT_GE(took, std::chrono::milliseconds(300));
    EXPECT_LT(took, std::chrono::milliseconds(1500)) << "answered by the cpu, not after the 3 s hang";
  }
  EXPECT_THAT(daemon->metrics().text(), ::testing::HasSubstr("rbdgrad_backend_timeouts_total{backend=\"fpga\"} 1"));
  EXPECT_THAT(daemon->metrics().text(), ::testing::HasSubstr("rbdgrad_failovers_total{from_backend=\"fpga\"} 1"));
  const BackendState* fpga = nullptr;
  for (const BackendState& b : daemon->backends().backends())
    if (b.name == "fpga") fpga = &b;
  ASSERT_NE(fpga, nullptr);
  EXPECT_TRUE(daemon->scheduler().suspect(*fpga));

  // the next request avoids the suspect fpga (its 20 us would win otherwise)
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_CPU);
  // pinned to it, with no other backend of its kind: waits for it (not refused, not moved)
  EXPECT_EQ(daemon->scheduler().backend_timeout_us(20), 300e3);

  // the hung call returns after 3 s: its result is dropped, and the fpga is trusted again
  for (int i = 0; i < 600 && daemon->scheduler().suspect(*fpga); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(daemon->scheduler().suspect(*fpga)) << "its late call succeeded";
  EXPECT_EQ(compute_auto(channel, 1, v1::PRECISION_AUTO).backend(), v1::BACKEND_FPGA);
  // every request answered once: the hung one counted once, by the cpu
  for (int i = 0; i < 400 && daemon->service().in_flight() != 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const std::string text = daemon->metrics().text();
  EXPECT_THAT(text, ::testing::HasSubstr("rbdgrad_requests_total{backend=\"cpu\",code=\"ok\",mode=\"none\","
                                         "model=\"iiwa14\",precision=\"f64\"} 2"));
  EXPECT_THAT(text, ::testing::HasSubstr("rbdgrad_requests_total{backend=\"fpga\",code=\"ok\",mode=\"none\","
                                         "model=\"iiwa14\",precision=\"fixed\"} 2"));
  const auto stop0 = std::chrono::steady_clock::now();
  daemon.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - stop0, std::chrono::seconds(5));
}

// Stopping while a timed-out call still hangs: its request was answered elsewhere; the daemon
// waits for the hung call to return (bounded by the fake) and stops cleanly.
TEST(DaemonRouting, TheDaemonStopsWhileATimedOutCallStillHangs) {
  DaemonOptions options = routing_options();
  options.config.plugins[0].options["hang_us"] = "1500000";
  options.config.scheduler.backend_timeout_ms = 150;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  v1::ComputeRequest hang = make_request("iiwa14", kIiwaNv, 1, 5, "hang", kCudaOutputs);
  set_value(hang.mutable_q(), 0, -998.0);
  hang.set_precision(v1::PRECISION_AUTO);
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(stub->Compute(&ctx, hang, &resp).ok());
  EXPECT_EQ(resp.backend(), v1::BACKEND_CPU);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(1000));
  stub.reset();
  daemon.reset();  // the fpga's pool thread returns from the hang, its result dropped
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_GE(took, std::chrono::milliseconds(1400)) << "the hung call was waited for";
  EXPECT_LT(took, std::chrono::seconds(5));
}

// A hung call that nothing else can take (pinned to its backend) is waited for: answered once,
// by that backend, late; the timeout still counts and marks it suspect until it succeeds.
TEST(DaemonRouting, AHungCallWithNowhereElseToGoIsWaitedFor) {
  DaemonOptions options = routing_options();
  options.config.plugins[0].options["hang_us"] = "800000";
  options.config.scheduler.backend_timeout_ms = 200;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  v1::ComputeRequest hang = make_request("iiwa14", kIiwaNv, 1, 5, "pinned", kCudaOutputs);
  set_value(hang.mutable_q(), 0, -998.0);
  hang.set_precision(v1::PRECISION_FIXED);
  hang.set_backend(v1::BACKEND_FPGA);
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const auto t0 = std::chrono::steady_clock::now();
  const grpc::Status s = stub->Compute(&ctx, hang, &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(800));
  EXPECT_EQ(resp.backend(), v1::BACKEND_FPGA);
  EXPECT_EQ(resp.failovers_size(), 0);
  EXPECT_THAT(daemon->metrics().text(), ::testing::HasSubstr("rbdgrad_backend_timeouts_total{backend=\"fpga\"} 1"));
  for (const BackendState& b : daemon->backends().backends()) {
    if (b.name == "fpga") {
      EXPECT_FALSE(daemon->scheduler().suspect(b)) << "its call succeeded in the end";
    }
  }
}

// A large request split across the cpu and cuda fakes (cpu 300 us + 2 us/state, cuda 3000 us +
// 1 us/state: 8192 states take cuda 11.2 ms alone, about 7.6 ms split). Each fake numbers the
// states of its share from 0 (output k + e / 1000), which shows where each share landed. A share
// whose backend fails as a whole makes the whole request run again on the next best backend.
TEST(DaemonRouting, SplitsALargeRequestAcrossBackends) {
  DaemonOptions options = routing_options();
  options.config.limits.max_states_per_request = 10000;
  options.config.plugins[1].options["fail_on_marker"] = "1";  // the cpu
  options.config.plugins[2].options["per_state_us"] = "1";    // the cuda
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  constexpr std::uint32_t kN = 8192;
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, kN, 7, "big", {v1::OUTPUT_DQDD_DQ});
  req.set_backend(v1::BACKEND_AUTO);
  v1::ComputeResponse resp;
  {
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  ASSERT_EQ(resp.parts_size(), 2);
  const v1::BatchPart& cpu = resp.parts(0);
  const v1::BatchPart& cuda = resp.parts(1);
  EXPECT_EQ(cpu.backend(), v1::BACKEND_CPU);
  EXPECT_EQ(cuda.backend(), v1::BACKEND_CUDA);
  EXPECT_EQ(cpu.first_state(), 0u);
  EXPECT_EQ(cuda.first_state(), cpu.num_states());
  EXPECT_EQ(cpu.num_states() + cuda.num_states(), kN);
  EXPECT_GT(cpu.num_states(), 2000u);  // 3630 by the exact sleeps
  EXPECT_GT(cuda.num_states(), 2000u);
  EXPECT_GE(cpu.compute_us(), 300u + 2u * cpu.num_states());
  EXPECT_GE(cuda.compute_us(), 3000u + cuda.num_states());
  EXPECT_EQ(resp.backend(), cpu.num_states() > cuda.num_states() ? v1::BACKEND_CPU : v1::BACKEND_CUDA);
  EXPECT_EQ(resp.timings().compute_us(), std::max(cpu.compute_us(), cuda.compute_us()));
  EXPECT_EQ(resp.num_states(), kN);
  const std::vector<double> d = values_of(resp.dqdd_dq());
  ASSERT_EQ(d.size(), std::size_t{kN} * kIiwaNv * kIiwaNv);
  const auto at = [&](std::size_t k, std::size_t e) { return d[k * kIiwaNv * kIiwaNv + e]; };
  EXPECT_EQ(at(0, 0), 0.0);
  EXPECT_EQ(at(cpu.num_states() - 1, 5), (cpu.num_states() - 1) + 0.005);
  EXPECT_EQ(at(cpu.num_states(), 5), 0.005) << "the cuda share starts at its own state 0";
  EXPECT_EQ(at(kN - 1, 48), (cuda.num_states() - 1) + 0.048);
  const std::string text = daemon->metrics().text();
  EXPECT_THAT(text, ::testing::HasSubstr("rbdgrad_split_requests_total 1"));
  EXPECT_THAT(text, ::testing::HasSubstr("rbdgrad_states_total{backend=\"cpu\",mode=\"none\"} " +
                                         std::to_string(cpu.num_states())));

  // the cpu's share fails as a whole ("device lost"): the whole request again on cuda
  set_value(req.mutable_q(), 0, -999.0);
  {
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  EXPECT_EQ(resp.parts_size(), 0);
  EXPECT_EQ(resp.backend(), v1::BACKEND_CUDA);
  ASSERT_EQ(resp.failovers_size(), 1);
  EXPECT_EQ(resp.failovers(0), "cpu: device lost");
  const std::vector<double> again = values_of(resp.dqdd_dq());
  ASSERT_EQ(again.size(), d.size());
  EXPECT_EQ(again[(kN - 1) * kIiwaNv * kIiwaNv], kN - 1.0) << "one backend numbered every state";

  // a state of the cuda share fails (numbered within the share): the whole request again on
  // cuda names it within the request
  set_value(req.mutable_q(), 0, 0.5);
  const std::uint32_t bad = cpu.num_states() + 3;
  set_value(req.mutable_q(), std::size_t{bad} * kIiwaNv, -997.0);
  {
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE) << s.error_message();
    EXPECT_THAT(s.error_message(), ::testing::HasSubstr("state " + std::to_string(bad) + ": singular mass matrix"));
  }

  // under split_min_states (4096 by default): one backend
  v1::ComputeRequest small = make_request("iiwa14", kIiwaNv, 4000, 8, "smaller", {v1::OUTPUT_DQDD_DQ});
  small.set_backend(v1::BACKEND_AUTO);
  grpc::ClientContext ctx;
  ASSERT_TRUE(stub->Compute(&ctx, small, &resp).ok());
  EXPECT_EQ(resp.parts_size(), 0);
}

}  // namespace
}  // namespace rbdgrad::server
