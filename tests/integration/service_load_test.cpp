// The real daemon under concurrent load and through a graceful shutdown: 32 client threads x 200
// requests of mixed sizes and call styles, all answered and all bit-exact; SIGTERM lets the
// requests in flight complete, then the daemon exits 0.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "integration_support.hpp"

namespace rbdgrad::testing {
namespace {

constexpr std::uint32_t kGradient = Output::kDqddDq | Output::kDqddDqd;

struct Case {
  Batch batch;
  std::uint32_t outputs;
  ComputeInput input;
  std::map<std::uint32_t, std::vector<double>> expected;
};

std::vector<Case> mixed_cases() {
  struct Spec {
    const char* robot;
    std::uint32_t n;
    std::uint32_t outputs;
    ComputeInput input;
  };
  const Spec specs[] = {
      {"iiwa14", 1, kGradient, ComputeInput::kTau},
      {"iiwa14", 5, kGradient | Output::kQdd, ComputeInput::kTau},
      {"iiwa14", 64, kGradient, ComputeInput::kTau},
      {"panda", 3, Output::kTau | Output::kDtauDq | Output::kDtauDqd, ComputeInput::kQdd},
      {"talos_reduced", 8, kGradient | Output::kMinv, ComputeInput::kTau},
      {"hyq", 17, Output::kM | Output::kQdd, ComputeInput::kTau},
  };
  std::vector<Case> cases;
  unsigned seed = 100;
  for (const Spec& s : specs) {
    const Model model = load_embedded(s.robot);
    Batch b = random_batch(s.robot, model.nv, s.n, seed++);
    auto expected = expected_outputs(model, b, s.outputs, s.input == ComputeInput::kTau);
    cases.push_back({std::move(b), s.outputs, s.input, std::move(expected)});
  }
  return cases;
}

TEST(ServiceLoad, ThirtyTwoThreadsTimesTwoHundredRequestsAllAnsweredAndExact) {
  DaemonProcess daemon(RBDGRADD_PATH, daemon_config());
  const std::vector<Case> cases = mixed_cases();
  constexpr int kThreads = 32, kRequests = 200;
  const Client shared(daemon.unix_address());
  std::atomic<int> answered{0}, exact{0};
  std::vector<std::string> failures(kThreads);

  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      // half the threads share one client (one connection), half have their own, over TCP
      std::unique_ptr<Client> own;
      if (t % 2) own = std::make_unique<Client>(daemon.tcp_address());
      const Client& client = own ? *own : shared;
      ComputeSession session;
      if (t % 4 == 3) session = client.open_session();
      ComputeResult result;
      for (int i = 0; i < kRequests; ++i) {
        const Case& c = cases[static_cast<size_t>(t + i) % cases.size()];
        ComputeRequest req = c.batch.request(c.outputs, c.input);
        req.request_id = std::to_string(t) + "/" + std::to_string(i);
        RpcStatus status;
        const ComputeResult* r = &result;
        switch (t % 4) {
          case 0:
          case 1:
            status = client.compute(req, result);
            break;
          case 2:
            try {
              result = client.compute_async(req).get();
            } catch (const ClientError& e) {
              status = RpcStatus(e.code(), e.what());
            }
            break;
          case 3:
            status = session.step(req, result);
            break;
        }
        if (!status) {
          if (failures[t].empty()) failures[t] = req.request_id + ": " + status.to_string();
          continue;
        }
        ++answered;
        if (r->request_id() == req.request_id && bitwise_equal(*r, c.expected)) {
          ++exact;
        } else if (failures[t].empty()) {
          failures[t] = req.request_id + ": wrong result";
        }
      }
      if (session.is_open()) session.close();
    });
  }
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_TRUE(failures[t].empty()) << "thread " << t << ": " << failures[t];
  EXPECT_EQ(answered.load(), kThreads * kRequests);
  EXPECT_EQ(exact.load(), kThreads * kRequests);
  // the daemon is still healthy afterwards and shuts down cleanly
  const std::optional<int> status = daemon.stop(SIGTERM);
  ASSERT_TRUE(status.has_value()) << daemon.log();
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0) << daemon.log();
}

TEST(ServiceShutdown, SigtermCompletesRequestsInFlightThenExitsZero) {
  DaemonProcess daemon(RBDGRADD_PATH, daemon_config());
  const Client client(daemon.unix_address());
  const Model model = load_embedded("iiwa14");
  // large batches queue behind each other on the CPU backend: tens of milliseconds each
  const Batch big = random_batch("iiwa14", model.nv, 20000, 9);
  constexpr int kCalls = 6;
  std::vector<std::future<ComputeResult>> calls;
  for (int i = 0; i < kCalls; ++i) calls.push_back(client.compute_async(big.request(kGradient)));
  // signal once the daemon is demonstrably working on them: the first answer is back
  bool first_done = false;
  while (!first_done) {
    for (auto& c : calls) first_done = first_done || c.wait_for(std::chrono::milliseconds(1)) == std::future_status::ready;
  }
  ::kill(daemon.pid(), SIGTERM);
  const auto expected = expected_outputs(model, random_batch("iiwa14", model.nv, 3, 9), kGradient, true);
  for (int i = 0; i < kCalls; ++i) {
    ComputeResult r;
    ASSERT_NO_THROW(r = calls[static_cast<size_t>(i)].get()) << "call " << i << "\n" << daemon.log();
    ASSERT_EQ(r.num_states(), 20000u);
    // the first three states are those of the same seed at N = 3
    const auto first3 = r.block(Output::kDqddDq).first(3 * 49);
    EXPECT_TRUE(std::equal(first3.begin(), first3.end(), expected.at(mask(Output::kDqddDq)).begin()));
  }
  const std::optional<int> status = daemon.stop(0);  // signal 0: wait for the exit, send nothing more
  ASSERT_TRUE(status.has_value()) << daemon.log();
  EXPECT_TRUE(WIFEXITED(*status)) << daemon.log();
  EXPECT_EQ(WEXITSTATUS(*status), 0) << daemon.log();
  EXPECT_FALSE(std::filesystem::exists(daemon.socket_path())) << "the daemon leaves its socket behind";
  // nothing listens any more
  ComputeResult r;
  EXPECT_EQ(client.compute(big.request(kGradient), r).code(), RpcCode::kUnavailable);
}

}  // namespace
}  // namespace rbdgrad::testing
