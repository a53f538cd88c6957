// Tests for the client's thread safety: many threads share one Client (one channel), mixing the
// sync and async paths; every answer belongs to its own request.
#include <gtest/gtest.h>

#include <atomic>
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

}  // namespace
}  // namespace rbdgrad::testing
