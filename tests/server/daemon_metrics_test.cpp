// The daemon's Prometheus metrics: served over HTTP at /metrics on the configured address, counting
// answered and refused requests by backend, model, precision and code, with the queues read at
// each scrape.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include "../support/http_get.hpp"
#include "daemon_test_support.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;
using rbdgrad::testing::http_get;


TEST(DaemonMetrics, CountsRequestsAndServesThemOverHttp) {
  DaemonOptions options = test_options("");
  options.config.metrics_listen = "127.0.0.1:0";
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  ASSERT_GT(daemon->metrics().port(), 0);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  for (const char* model : {"iiwa14", "atlas"}) {  // one answered, one refused (unknown model)
    grpc::ClientContext ctx;
    v1::ComputeResponse resp;
    (void)stub->Compute(&ctx, make_request(model, kIiwaNv, 5, 1, "m"), &resp);
  }
  // a request counts as in flight until gRPC is done with its response, a little after the client
  // has it
  for (int i = 0; i < 400 && daemon->service().in_flight() != 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const std::string scraped = http_get(daemon->metrics().port(), "/metrics");
  EXPECT_THAT(scraped, HasSubstr("200 OK"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_requests_total{backend=\"cpu\",code=\"ok\",mode=\"none\",model=\"iiwa14\","
                                 "precision=\"f64\"} 1"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_requests_total{backend=\"none\",code=\"not_found\",mode=\"none\","
                                 "model=\"none\",precision=\"none\"} 1"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_states_total{backend=\"cpu\",mode=\"none\"} 5"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_batch_states_count{backend=\"cpu\",mode=\"none\"} 1"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_compute_seconds_count{backend=\"cpu\",mode=\"none\"} 1"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_queue_requests{backend=\"cpu\",model=\"iiwa14\",state=\"queued\"} 0"));
  EXPECT_THAT(scraped, HasSubstr("rbdgrad_requests_in_flight 0"));
  // the same text without HTTP
  EXPECT_THAT(daemon->metrics().text(), HasSubstr("rbdgrad_states_total{backend=\"cpu\",mode=\"none\"} 5"));
}

TEST(DaemonMetrics, AnAddressInUseIsAnError) {
  DaemonOptions first = test_options("");
  first.config.metrics_listen = "127.0.0.1:0";
  std::unique_ptr<Daemon> a = start_daemon(std::move(first));
  ASSERT_NE(a, nullptr);
  DaemonOptions second = test_options("");
  second.config.metrics_listen = "127.0.0.1:" + std::to_string(a->metrics().port());
  std::unique_ptr<Daemon> b;
  const Status s = Daemon::create(std::move(second), b);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_THAT(s.message(), HasSubstr("metrics: cannot serve on 127.0.0.1:"));
}

}  // namespace
}  // namespace rbdgrad::server
