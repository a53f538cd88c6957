// Dynamic batching in the daemon (server/coalescer.cpp): concurrent small requests share one
// backend call, each caller gets exactly the results it would get alone, a request with a failed
// state fails alone with its own message while the others of its group succeed, and a group that
// reaches the preferred size does not wait for the delay.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include "daemon_test_support.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;

DaemonOptions batching_options(std::int64_t delay_us, std::int64_t preferred) {
  DaemonOptions options = test_options("");
  options.config.limits.max_queue_delay_us = delay_us;
  options.config.scheduler.preferred_batch_states = preferred;
  return options;
}

struct Answer {
  grpc::Status status;
  v1::ComputeResponse response;
};

// every request at once, each on its own thread
std::vector<Answer> compute_together(const std::shared_ptr<grpc::Channel>& channel,
                                     const std::vector<v1::ComputeRequest>& requests) {
  std::vector<Answer> answers(requests.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < requests.size(); ++i) {
    threads.emplace_back([&, i] {
      auto stub = v1::Dynamics::NewStub(channel);
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
      answers[i].status = stub->Compute(&ctx, requests[i], &answers[i].response);
    });
  }
  for (std::thread& t : threads) t.join();
  return answers;
}

// Eight iiwa14 requests of 3 to 10 states at once on the CPU backend: with a 200 ms delay they
// share backend calls, and every output is bit for bit what a daemon without batching returns.
TEST(DaemonBatching, CoalescedResultsEqualUnbatchedResultsExactly) {
  std::vector<v1::ComputeRequest> requests;
  for (int i = 0; i < 8; ++i)
    requests.push_back(make_request("iiwa14", kIiwaNv, static_cast<std::uint32_t>(3 + i), 40 + i,
                                    "r" + std::to_string(i)));
  std::unique_ptr<Daemon> batching = start_daemon(batching_options(200000, 256));
  ASSERT_NE(batching, nullptr);
  const std::vector<Answer> together = compute_together(channel_to(batching->addresses()[0]), requests);
  std::unique_ptr<Daemon> plain = start_daemon(test_options(""));
  ASSERT_NE(plain, nullptr);
  const std::vector<Answer> alone = compute_together(channel_to(plain->addresses()[0]), requests);
  std::uint32_t most = 0;
  for (std::size_t i = 0; i < requests.size(); ++i) {
    ASSERT_TRUE(together[i].status.ok()) << together[i].status.error_message();
    ASSERT_TRUE(alone[i].status.ok()) << alone[i].status.error_message();
    const v1::ComputeResponse& a = together[i].response;
    const v1::ComputeResponse& b = alone[i].response;
    EXPECT_EQ(a.request_id(), requests[i].request_id());
    EXPECT_EQ(a.num_states(), requests[i].num_states());
    EXPECT_EQ(b.batch_requests(), 1u);
    most = std::max(most, a.batch_requests());
    for (v1::Output o : kAllOutputs) {
      EXPECT_EQ(response_tensor(const_cast<v1::ComputeResponse&>(a), o)->data(),
                response_tensor(const_cast<v1::ComputeResponse&>(b), o)->data())
          << "request " << i << ", output " << o;
    }
  }
  EXPECT_GE(most, 2u) << "no two requests shared a backend call within 200 ms";
}

// A scripted failure in one request of a group (the fake cuda backend: u = 777) fails that request
// alone, naming its own state; the others of the group succeed.
TEST(DaemonBatching, AFailedStateFailsOnlyItsRequest) {
  std::unique_ptr<Daemon> daemon = start_daemon(batching_options(200000, 256));
  ASSERT_NE(daemon, nullptr);
  std::vector<v1::ComputeRequest> requests;
  for (int i = 0; i < 4; ++i) {
    requests.push_back(make_request("iiwa14", kIiwaNv, 4, 60 + i, "f" + std::to_string(i), kCudaOutputs));
    requests.back().set_backend(v1::BACKEND_CUDA);
  }
  set_value(requests[2].mutable_u(), 3 * kIiwaNv, 777.0);  // its state 3
  const std::vector<Answer> answers = compute_together(channel_to(daemon->addresses()[0]), requests);
  std::uint32_t most = 0;
  for (std::size_t i = 0; i < answers.size(); ++i) {
    if (i == 2) {
      EXPECT_EQ(answers[i].status.error_code(), grpc::StatusCode::OUT_OF_RANGE);
      EXPECT_EQ(answers[i].status.error_message(), "request 'f2': cuda: state 3: scripted numerical failure");
    } else {
      EXPECT_TRUE(answers[i].status.ok()) << i << ": " << answers[i].status.error_message();
      most = std::max(most, answers[i].response.batch_requests());
    }
  }
  EXPECT_GE(most, 2u) << "the requests were not grouped: the test shows nothing";
}

// A group that reaches the preferred size goes at once, not after the (long) delay.
TEST(DaemonBatching, AFullGroupDoesNotWaitForTheDelay) {
  std::unique_ptr<Daemon> daemon = start_daemon(batching_options(10000000, 8));  // 10 s, 8 states
  ASSERT_NE(daemon, nullptr);
  const std::vector<v1::ComputeRequest> requests = {make_request("iiwa14", kIiwaNv, 4, 1, "a"),
                                                    make_request("iiwa14", kIiwaNv, 4, 2, "b")};
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Answer> answers = compute_together(channel_to(daemon->addresses()[0]), requests);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  for (const Answer& a : answers) {
    ASSERT_TRUE(a.status.ok()) << a.status.error_message();
    EXPECT_EQ(a.response.batch_requests(), 2u);
  }
  // a request of the preferred size or more never waits
  const std::vector<Answer> big = compute_together(channel_to(daemon->addresses()[0]),
                                                   {make_request("iiwa14", kIiwaNv, 8, 3, "big")});
  ASSERT_TRUE(big[0].status.ok()) << big[0].status.error_message();
  EXPECT_EQ(big[0].response.batch_requests(), 1u);
}

}  // namespace
}  // namespace rbdgrad::server
