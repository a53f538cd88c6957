// Tests for client/src/client.cpp and compute_session.cpp: the sync, async (future and callback)
// and streaming paths, the server's errors as codes and messages, deadlines, an absent server.
#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <thread>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"
#include "test_batch.hpp"

namespace rbdgrad::testing {
namespace {

using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

class ComputeCallsTest : public ::testing::Test {
 protected:
  FakeServer server_;
  Client client_{server_.address()};
  TestBatch batch_{4, 3};

  ComputeRequest request(std::string model = "iiwa14") const {
    ComputeRequest r = batch_.request(std::move(model));
    r.outputs = Output::kQdd | Output::kDqddDq;
    return r;
  }
};

TEST_F(ComputeCallsTest, SyncThrowsTheServersCodeAndMessage) {
  try {
    (void)client_.compute(request("broken"));
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kInvalidArgument);
    EXPECT_EQ(e.message(), kBrokenMessage);
    EXPECT_EQ(std::string(e.what()), std::string("INVALID_ARGUMENT: ") + kBrokenMessage);
  }
  try {
    (void)client_.compute(request("unknown"));
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kNotFound);
    EXPECT_EQ(e.message(), kUnknownMessage);
  }
}

TEST_F(ComputeCallsTest, TheStatusFormNeverThrows) {
  ComputeResult r;
  RpcStatus st = client_.compute(request("unknown"), r);
  EXPECT_EQ(st.code(), RpcCode::kNotFound);
  EXPECT_EQ(st.to_string(), std::string("NOT_FOUND: ") + kUnknownMessage);
  st = client_.compute(request(), r);
  EXPECT_TRUE(st.is_ok()) << st.to_string();
  EXPECT_EQ(check_result_values(r, batch_), "");
}

TEST_F(ComputeCallsTest, AsyncFutureGivesTheResultOrThrows) {
  std::future<ComputeResult> ok = client_.compute_async(request());
  std::future<ComputeResult> bad = client_.compute_async(request("broken"));
  const ComputeResult r = ok.get();
  EXPECT_EQ(check_result_values(r, batch_), "");
  try {
    (void)bad.get();
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kInvalidArgument);
    EXPECT_EQ(e.message(), kBrokenMessage);
  }
}

TEST_F(ComputeCallsTest, AsyncCallbacksRunOncePerCall) {
  constexpr int kCalls = 6;
  std::mutex m;
  std::condition_variable cv;
  int done = 0, failed = 0;
  std::string mismatch;
  for (int c = 0; c < kCalls; ++c) {
    ComputeRequest req = request(c == 3 ? "unknown" : "iiwa14");
    req.request_id = "cb-" + std::to_string(c);
    client_.compute_async(req, [&, c](RpcStatus st, ComputeResult r) {
      std::lock_guard lock(m);
      if (!st) {
        ++failed;
        if (c != 3 || st.code() != RpcCode::kNotFound) mismatch += "call " + std::to_string(c) + ": " + st.to_string();
      } else {
        if (r.request_id() != "cb-" + std::to_string(c)) mismatch += "request_id " + r.request_id();
        mismatch += check_result_values(r, batch_);
      }
      ++done;
      cv.notify_all();
    });
  }
  std::unique_lock lock(m);
  ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(10), [&] { return done == kCalls; }));
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(mismatch, "");
}

TEST_F(ComputeCallsTest, ASessionAnswersEveryStepInOrder) {
  ComputeSession session = client_.open_session();
  ASSERT_TRUE(session.is_open());
  const ComputeResult* first = nullptr;
  for (int s = 0; s < 5; ++s) {
    const TestBatch step_batch(static_cast<std::uint32_t>(1 + s), 3, 10.0 * s);
    ComputeRequest req = step_batch.request();
    req.outputs = Output::kQdd | Output::kDqddDqd;
    req.request_id = "step-" + std::to_string(s);
    const ComputeResult& r = session.step(req);
    if (!first) first = &r;
    EXPECT_EQ(&r, first) << "step results live in the session";
    EXPECT_EQ(r.request_id(), req.request_id);
    EXPECT_EQ(r.num_states(), step_batch.n);
    EXPECT_EQ(check_result_values(r, step_batch), "");
  }
  // the status form, into the caller's own result
  ComputeResult mine;
  ASSERT_TRUE(session.step(request(), mine));
  EXPECT_EQ(check_result_values(mine, batch_), "");
  EXPECT_TRUE(session.close());
  EXPECT_FALSE(session.is_open());
  EXPECT_TRUE(session.close()) << "closing again gives the same status";
  EXPECT_EQ(server_.service().stream_count(), 1);
  EXPECT_EQ(server_.service().received().size(), 6u);
}

TEST_F(ComputeCallsTest, AFailedStepEndsTheSessionWithTheServersStatus) {
  ComputeSession session = client_.open_session();
  ComputeResult first;
  ASSERT_TRUE(session.step(request(), first));
  try {
    (void)session.step(request("broken"));
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kInvalidArgument);
    EXPECT_EQ(e.message(), kBrokenMessage);
  }
  EXPECT_FALSE(session.is_open());
  ComputeResult r;
  const RpcStatus st = session.step(request(), r);
  EXPECT_EQ(st.code(), RpcCode::kFailedPrecondition);
  EXPECT_NE(st.message().find("the session is closed (it ended with INVALID_ARGUMENT"), std::string::npos) << st.message();
  EXPECT_EQ(session.close().code(), RpcCode::kInvalidArgument);
  // a default session was never opened
  ComputeSession none;
  EXPECT_FALSE(none.is_open());
  EXPECT_EQ(none.step(request(), r).code(), RpcCode::kFailedPrecondition);
}

TEST_F(ComputeCallsTest, DeadlinesEndSlowCalls) {
  ComputeRequest req = request("slow");
  req.timeout = milliseconds(100);
  const Clock::time_point start = Clock::now();
  ComputeResult r;
  EXPECT_EQ(client_.compute(req, r).code(), RpcCode::kDeadlineExceeded);
  std::future<ComputeResult> f = client_.compute_async(req);
  try {
    (void)f.get();
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kDeadlineExceeded);
  }
  // the client's default applies when the request sets none
  ClientOptions options;
  options.default_timeout = milliseconds(100);
  Client quick(server_.address(), options);
  req.timeout.reset();
  EXPECT_EQ(quick.compute(req, r).code(), RpcCode::kDeadlineExceeded);
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(3)) << "the slow model answers after 5 s";
}

TEST_F(ComputeCallsTest, ASlowStepEndsTheSessionAtItsDeadline) {
  SessionOptions options;
  options.step_timeout = milliseconds(100);
  ComputeSession session = client_.open_session(options);
  ComputeResult r;
  ASSERT_TRUE(session.step(request(), r)) << "a fast step passes";
  const Clock::time_point start = Clock::now();
  const RpcStatus st = session.step(request("slow"), r);
  EXPECT_EQ(st.code(), RpcCode::kDeadlineExceeded) << st.to_string();
  EXPECT_NE(st.message().find("exceeded its timeout of 100 ms"), std::string::npos) << st.message();
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(3));
  EXPECT_FALSE(session.is_open());
}

TEST_F(ComputeCallsTest, ManyStepsWithinTheirDeadlineKeepTheSessionOpen) {
  // each step arms and disarms its alarm: none may fire for an earlier step
  SessionOptions options;
  options.step_timeout = milliseconds(200);
  ComputeSession session = client_.open_session(options);
  ComputeResult r;
  for (int s = 0; s < 200; ++s) ASSERT_TRUE(session.step(request(), r)) << "step " << s;
  std::this_thread::sleep_for(milliseconds(300));  // past every armed deadline
  ASSERT_TRUE(session.step(request(), r));
  EXPECT_TRUE(session.close());
}

TEST(ClientWithoutServer, CallsFailAsUnavailable) {
  Client client(unused_address());
  const TestBatch batch(1, 2);
  ComputeRequest req = batch.request();
  req.outputs = mask(Output::kQdd);
  ComputeResult r;
  const Clock::time_point start = Clock::now();
  EXPECT_EQ(client.compute(req, r).code(), RpcCode::kUnavailable);
  std::vector<ServedModel> models;
  EXPECT_EQ(client.list_models(models).code(), RpcCode::kUnavailable);
  EXPECT_THROW((void)client.server_info(), ClientError);
  ComputeSession session = client.open_session();
  EXPECT_EQ(session.step(req, r).code(), RpcCode::kUnavailable);
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5)) << "fail fast, no waiting for a server";
}

TEST(ClientWithoutServer, WaitForReadyWaitsUntilTheDeadline) {
  ClientOptions options;
  options.wait_for_ready = true;
  options.default_timeout = milliseconds(200);
  Client client(unused_address(), options);
  std::vector<ServedModel> models;
  const Clock::time_point start = Clock::now();
  EXPECT_EQ(client.list_models(models).code(), RpcCode::kDeadlineExceeded);
  EXPECT_GE(Clock::now() - start, milliseconds(150));
}

}  // namespace
}  // namespace rbdgrad::testing
