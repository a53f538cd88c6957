// Tests of the client's retries (RetryPolicy: UNAVAILABLE only, backoff with jitter, within the
// call's deadline, sessions never replayed) and of several server addresses (round_robin), against
// fake servers that fail their first k calls with UNAVAILABLE.
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"
#include "test_batch.hpp"

namespace rbdgrad::testing {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;
using Clock = std::chrono::steady_clock;

ComputeRequest small_request(const TestBatch& batch) {
  ComputeRequest r = batch.request();
  r.outputs = mask(Output::kQdd);
  return r;
}

TEST(RetryBackoff, GrowsByTheMultiplierUpToTheCap) {
  const RetryPolicy p;  // 10 ms, x2, 1 s, full jitter
  EXPECT_EQ(p.max_attempts, 4);
  // u = 0: the top of the range, b itself
  const nanoseconds expected[] = {milliseconds(10), milliseconds(20), milliseconds(40),  milliseconds(80),
                                  milliseconds(160), milliseconds(320), milliseconds(640), milliseconds(1000),
                                  milliseconds(1000), milliseconds(1000)};
  for (int k = 1; k <= 10; ++k) EXPECT_EQ(retry_backoff(p, k, 0.0), expected[k - 1]) << "retry " << k;
  EXPECT_EQ(retry_backoff(p, 1000, 0.0), milliseconds(1000)) << "no overflow past the cap";
}

TEST(RetryBackoff, FullJitterSpansZeroToTheBackoff) {
  const RetryPolicy p;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  nanoseconds lo = milliseconds(1000), hi{0};
  for (int i = 0; i < 2000; ++i) {
    const nanoseconds d = retry_backoff(p, 3, u(rng));  // b = 40 ms
    ASSERT_GE(d, nanoseconds(0));
    ASSERT_LE(d, milliseconds(40));
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  EXPECT_LT(lo, milliseconds(4)) << "the draws reach near 0";
  EXPECT_GT(hi, milliseconds(36)) << "and near the backoff";
}

TEST(RetryBackoff, PartialAndNoJitter) {
  RetryPolicy p;
  p.initial_backoff = milliseconds(100);
  p.multiplier = 3;
  p.max_backoff = milliseconds(500);
  p.jitter = 0.25;  // [75%, 100%] of b
  for (double u : {0.0, 0.3, 0.6, 0.999}) {
    EXPECT_GE(retry_backoff(p, 2, u), milliseconds(225));  // b = 300 ms
    EXPECT_LE(retry_backoff(p, 2, u), milliseconds(300));
    EXPECT_GE(retry_backoff(p, 3, u), milliseconds(375));  // b = 900 ms, capped at 500
    EXPECT_LE(retry_backoff(p, 3, u), milliseconds(500));
  }
  p.jitter = 0;
  EXPECT_EQ(retry_backoff(p, 1, 0.9), milliseconds(100));
}

TEST(RetryPolicyOptions, OutOfRangeIsRefusedAtConstruction) {
  const auto refused = [](auto change) {
    ClientOptions o;
    change(o.retry);
    try {
      Client c("127.0.0.1:1", o);
    } catch (const ClientError& e) {
      return e.code() == RpcCode::kInvalidArgument;
    }
    return false;
  };
  EXPECT_TRUE(refused([](RetryPolicy& r) { r.max_attempts = 0; }));
  EXPECT_TRUE(refused([](RetryPolicy& r) { r.initial_backoff = milliseconds(-1); }));
  EXPECT_TRUE(refused([](RetryPolicy& r) { r.multiplier = 0.5; }));
  EXPECT_TRUE(refused([](RetryPolicy& r) { r.jitter = 1.5; }));
  EXPECT_FALSE(refused([](RetryPolicy& r) { r.max_attempts = 1; }));
}

class RetryTest : public ::testing::Test {
 protected:
  FakeServer server_;
  TestBatch batch_{2, 3};
};

TEST_F(RetryTest, UnavailableIsRetriedWithGrowingPausesUntilItSucceeds) {
  ClientOptions o;
  o.retry.initial_backoff = milliseconds(30);
  o.retry.jitter = 0;  // exact pauses: 30, 60 ms
  const Client client(server_.address(), o);
  server_.service().fail_next(2);
  ComputeResult r;
  const RpcStatus st = client.compute(small_request(batch_), r);
  ASSERT_TRUE(st.is_ok()) << st.to_string();
  EXPECT_EQ(check_result_values(r, batch_), "");
  EXPECT_EQ(r.timings().attempts, 3u);
  EXPECT_EQ(client.retry_stats().retries, 2u);
  EXPECT_EQ(client.retry_stats().gave_up, 0u);
  const auto times = server_.service().call_times();
  ASSERT_EQ(times.size(), 3u);
  EXPECT_GE(times[1] - times[0], milliseconds(30));
  EXPECT_GE(times[2] - times[1], milliseconds(60));
  // a call that succeeds at once says so
  ASSERT_TRUE(client.compute(small_request(batch_), r).is_ok());
  EXPECT_EQ(r.timings().attempts, 1u);
}

TEST_F(RetryTest, GivesUpAfterMaxAttempts) {
  ClientOptions o;
  o.retry.max_attempts = 3;
  o.retry.initial_backoff = milliseconds(1);
  const Client client(server_.address(), o);
  server_.service().fail_next(100);
  ComputeResult r;
  const RpcStatus st = client.compute(small_request(batch_), r);
  EXPECT_EQ(st.code(), RpcCode::kUnavailable);
  EXPECT_EQ(st.message(), "injected failure");
  EXPECT_EQ(server_.service().call_times().size(), 3u);
  EXPECT_EQ(client.retry_stats().retries, 2u);
  EXPECT_EQ(client.retry_stats().gave_up, 1u);
}

TEST_F(RetryTest, MaxAttemptsOneMeansNoRetry) {
  ClientOptions o;
  o.retry.max_attempts = 1;
  const Client client(server_.address(), o);
  server_.service().fail_next(1);
  ComputeResult r;
  EXPECT_EQ(client.compute(small_request(batch_), r).code(), RpcCode::kUnavailable);
  EXPECT_EQ(server_.service().call_times().size(), 1u);
  EXPECT_EQ(client.retry_stats().retries, 0u);
}

TEST_F(RetryTest, OtherCodesAreNotRetried) {
  const Client client(server_.address());
  ComputeResult r;
  for (grpc::StatusCode code : {grpc::StatusCode::INTERNAL, grpc::StatusCode::RESOURCE_EXHAUSTED,
                                grpc::StatusCode::UNKNOWN, grpc::StatusCode::ABORTED}) {
    server_.service().fail_next(1, code);
    const RpcStatus st = client.compute(small_request(batch_), r);
    EXPECT_EQ(static_cast<int>(st.code()), static_cast<int>(code));
  }
  // the server's own answers (INVALID_ARGUMENT, NOT_FOUND)
  ComputeRequest unknown = small_request(batch_);
  unknown.model = "unknown";
  EXPECT_EQ(client.compute(unknown, r).code(), RpcCode::kNotFound);
  EXPECT_EQ(server_.service().call_times().size(), 5u) << "one call each";
  EXPECT_EQ(client.retry_stats().retries, 0u);
  EXPECT_EQ(client.retry_stats().gave_up, 0u);
}

TEST_F(RetryTest, NoRetryPastTheDeadline) {
  ClientOptions o;
  o.retry.max_attempts = 10;
  o.retry.initial_backoff = milliseconds(600);
  o.retry.multiplier = 4;  // the second pause (2.4 s) would end past the 2 s deadline
  o.retry.max_backoff = std::chrono::seconds(10);
  o.retry.jitter = 0;
  const Client client(server_.address(), o);
  server_.service().fail_next(100);
  ComputeRequest req = small_request(batch_);
  req.timeout = std::chrono::seconds(2);
  ComputeResult r;
  const Clock::time_point start = Clock::now();
  const RpcStatus st = client.compute(req, r);
  const auto elapsed = Clock::now() - start;
  EXPECT_EQ(st.code(), RpcCode::kUnavailable) << "the last attempt's status, without waiting out the deadline";
  EXPECT_EQ(server_.service().call_times().size(), 2u);
  EXPECT_GE(elapsed, milliseconds(600));
  EXPECT_LT(elapsed, std::chrono::seconds(2)) << "gave up when the next pause would pass the deadline";
  EXPECT_EQ(client.retry_stats().gave_up, 1u);
}

TEST_F(RetryTest, AsyncCallsAreRetriedToo) {
  const Client client(server_.address());
  server_.service().fail_next(2);
  std::future<ComputeResult> f = client.compute_async(small_request(batch_));
  const ComputeResult r = f.get();
  EXPECT_EQ(check_result_values(r, batch_), "");
  EXPECT_EQ(r.timings().attempts, 3u);
  EXPECT_EQ(client.retry_stats().retries, 2u);

  // and give up like sync calls
  ClientOptions o;
  o.retry.max_attempts = 2;
  const Client impatient(server_.address(), o);
  server_.service().fail_next(5);
  EXPECT_THROW((void)impatient.compute_async(small_request(batch_)).get(), ClientError);
  EXPECT_EQ(impatient.retry_stats().gave_up, 1u);
}

TEST_F(RetryTest, DescriptionCallsAreRetried) {
  const Client client(server_.address());
  server_.service().fail_next(1);
  EXPECT_EQ(client.list_models().size(), 2u);
  server_.service().fail_next(2);
  EXPECT_EQ(client.server_info().version, "9.8.7-fake");
  EXPECT_EQ(client.retry_stats().retries, 3u);
}

TEST_F(RetryTest, ASessionIsNeverReplayed) {
  const Client client(server_.address());
  server_.service().fail_next(1);
  ComputeSession session = client.open_session();
  ComputeResult r;
  EXPECT_EQ(session.step(small_request(batch_), r).code(), RpcCode::kUnavailable);
  EXPECT_FALSE(session.is_open());
  EXPECT_EQ(server_.service().stream_count(), 1) << "one stream, not opened again";
  EXPECT_EQ(client.retry_stats().retries, 0u);
  // a new session is the caller's choice
  ComputeSession again = client.open_session();
  EXPECT_TRUE(again.step(small_request(batch_), r).is_ok());
}

TEST(SeveralAddresses, RoundRobinSpreadsCallsOverEveryServer) {
  FakeServer a, b, c;
  const Client client({a.address(), b.address(), c.address()});
  EXPECT_EQ(client.address(), "ipv4:" + a.address() + "," + b.address() + "," + c.address());
  const TestBatch batch(1, 2);
  // the first calls may all go to the first server ready; round_robin uses all once connected
  for (int i = 0; i < 60; ++i) ASSERT_TRUE(client.compute(small_request(batch)).valid());
  EXPECT_GE(a.service().received().size(), 10u);
  EXPECT_GE(b.service().received().size(), 10u);
  EXPECT_GE(c.service().received().size(), 10u);
}

TEST(SeveralAddresses, ADnsTargetGetsRoundRobinAndWorks) {
  // "localhost" may resolve to ::1 as well, where nothing listens: round_robin uses the address up
  FakeServer server;
  const std::string port = server.address().substr(server.address().rfind(':') + 1);
  const Client client("dns:///localhost:" + port);
  const TestBatch batch(1, 2);
  for (int i = 0; i < 5; ++i) {
    ComputeResult r;
    const RpcStatus st = client.compute(small_request(batch), r);
    ASSERT_TRUE(st.is_ok()) << st.to_string();
  }
}

TEST(SeveralAddresses, AServerGoneIsLeftForTheOthers) {
  auto a = std::make_unique<FakeServer>();
  FakeServer b;
  const std::vector<std::string> addresses = {a->address(), b.address()};
  const Client client(addresses);
  const TestBatch batch(1, 2);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(client.compute(small_request(batch)).valid());
  a.reset();  // shut down
  for (int i = 0; i < 40; ++i) {
    ComputeResult r;
    const RpcStatus st = client.compute(small_request(batch), r);
    ASSERT_TRUE(st.is_ok()) << "call " << i << ": " << st.to_string();
  }
}

TEST(SeveralAddresses, AListMustBeIpAddressesOfOneFamily) {
  const auto code = [](std::vector<std::string> addresses) {
    try {
      Client c(addresses);
      return RpcCode::kOk;
    } catch (const ClientError& e) {
      return e.code();
    }
  };
  EXPECT_EQ(code({}), RpcCode::kInvalidArgument);
  EXPECT_EQ(code({"localhost:5001", "127.0.0.1:5002"}), RpcCode::kInvalidArgument);
  EXPECT_EQ(code({"unix:/tmp/a.sock", "unix:/tmp/b.sock"}), RpcCode::kInvalidArgument);
  EXPECT_EQ(code({"127.0.0.1:5001", "[::1]:5002"}), RpcCode::kInvalidArgument);
  EXPECT_EQ(code({"127.0.0.1", "127.0.0.1:5002"}), RpcCode::kInvalidArgument);
  EXPECT_EQ(code({"[::1]:5001", "[::1]:5002"}), RpcCode::kOk);
  EXPECT_EQ(Client(std::vector<std::string>{"[::1]:5001", "[::1]:5002"}).address(), "ipv6:[::1]:5001,[::1]:5002");
  // one entry is the single-address client, whatever its form
  EXPECT_EQ(code({"unix:/tmp/a.sock"}), RpcCode::kOk);
  EXPECT_EQ(Client(std::vector<std::string>{"localhost:5001"}).address(), "localhost:5001");
}

}  // namespace
}  // namespace rbdgrad::testing
