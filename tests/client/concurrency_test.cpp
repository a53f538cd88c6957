// Tests for the client's thread safety: many threads share one Client (one channel), mixing the
// sync and async paths; every answer belongs to its own request.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <memory>
#include <thread>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"
#include "test_batch.hpp"

namespace rbdgrad::testing {
namespace {

TEST(ClientConcurrency, ThreadsShareOneClient) {
  FakeServer server;
  const Client client(server.address());
  constexpr int kThreads = 8, kCalls = 40;
  std::atomic<int> good{0};
  std::vector<std::string> problems(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      ComputeResult reused;
      for (int c = 0; c < kCalls; ++c) {
        // inputs unique to (thread, call), sizes varying
        const TestBatch batch(static_cast<std::uint32_t>(1 + (t + c) % 5), 2 + t % 3, 1000.0 * t + c);
        ComputeRequest req = batch.request();
        req.outputs = Output::kQdd | Output::kDtauDq;
        req.request_id = std::to_string(t) + "/" + std::to_string(c);
        std::string problem;
        if (c % 3 == 0) {
          ComputeResult r = client.compute_async(req).get();
          problem = check_result_values(r, batch);
          if (r.request_id() != req.request_id) problem += " wrong request_id " + r.request_id();
        } else {
          const RpcStatus st = client.compute(req, reused);
          problem = st ? check_result_values(reused, batch) : st.to_string();
          if (st && reused.request_id() != req.request_id) problem += " wrong request_id " + reused.request_id();
        }
        if (problem.empty()) ++good;
        else if (problems[static_cast<std::size_t>(t)].empty()) problems[static_cast<std::size_t>(t)] = problem;
      }
    });
  }
  for (std::thread& th : threads) th.join();
  EXPECT_EQ(good.load(), kThreads * kCalls);
  for (const std::string& p : problems) EXPECT_EQ(p, "");
  EXPECT_EQ(server.service().received().size(), static_cast<std::size_t>(kThreads * kCalls));
}

TEST(ClientConcurrency, TheClientMayGoWhileAsyncCallsAnswer) {
  // The caller learns of the answer on a gRPC thread; destroying the Client (its channel) right
  // after, or even before, must not race with the call's own clean-up on that thread.
  FakeServer server;
  const TestBatch batch(2, 3);
  ComputeRequest req = batch.request();
  req.outputs = Output::kQdd | Output::kDtauDq;
  for (int round = 0; round < 100; ++round) {
    auto client = std::make_unique<Client>(server.address());
    std::promise<RpcStatus> answered;
    client->compute_async(req, [&](RpcStatus st, ComputeResult) { answered.set_value(std::move(st)); });
    const RpcStatus st = answered.get_future().get();
    client.reset();
    ASSERT_TRUE(st) << "round " << round << ": " << st.to_string();
    // destroyed with the call still in flight: the destructor waits for it
    std::promise<RpcStatus> late;
    auto other = std::make_unique<Client>(server.address());
    other->compute_async(req, [&](RpcStatus s, ComputeResult) { late.set_value(std::move(s)); });
    other.reset();
    const RpcStatus late_status = late.get_future().get();
    ASSERT_TRUE(late_status) << "round " << round << ": " << late_status.to_string();
  }
}

}  // namespace
}  // namespace rbdgrad::testing
