// Three real daemons on loopback ports and one client given the three addresses (round_robin,
// retries): the load is spread over the three (each one's rbdgrad_requests_total, scraped from its
// /metrics), and a daemon killed in the middle of a wave of requests loses none of them: the calls
// it held fail with UNAVAILABLE and the client sends them again to the two others.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <memory>
#include <cstdio>
#include <regex>
#include <sstream>
#include <thread>

#include "../support/http_get.hpp"
#include "integration_support.hpp"

namespace rbdgrad::testing {
namespace {

using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kGradient = Output::kQdd | Output::kDqddDq | Output::kDqddDqd;

// light daemons: one small model, no start-up calibration, metrics on an ephemeral port (logged)
const char* kConfig = R"(models:
  - name: iiwa14
    embedded: iiwa14
log_level: info
scheduler:
  calibrate: off
metrics:
  listen: "127.0.0.1:0"
)";


// The metrics port the daemon logged ("metrics: http://127.0.0.1:PORT/metrics"); 0 if not within 20 s.
int metrics_port(const DaemonProcess& d) {
  const std::regex line(R"(metrics: http://127\.0\.0\.1:([0-9]+)/metrics)");
  for (const auto until = Clock::now() + std::chrono::seconds(20); Clock::now() < until;) {
    std::smatch m;
    const std::string log = d.log();
    if (std::regex_search(log, m, line)) return std::stoi(m[1]);
    std::this_thread::sleep_for(milliseconds(20));
  }
  return 0;
}

// Compute requests the daemon answered: the sum of its rbdgrad_requests_total series.
double requests_answered(int port) {
  const std::string text = http_get(port, "/metrics");
  double sum = 0;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (l.rfind("rbdgrad_requests_total{", 0) == 0) sum += std::stod(l.substr(l.rfind(' ') + 1));
  return sum;
}

struct Case {
  Batch batch;
  std::map<std::uint32_t, std::vector<double>> expected;
};

// `threads` threads x `per_thread` requests through `client`, odd threads asynchronously (a
// future); every result checked bit for bit. `done` counts the calls completed.
struct Wave {
  std::vector<std::string> failures;
  std::uint32_t most_attempts = 0;
  int retried_results = 0;
};

Wave run_wave(const Client& client, const std::vector<Case>& cases, int threads, int per_thread,
              std::atomic<int>& done) {
  std::vector<Wave> per(static_cast<std::size_t>(threads));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      Wave& w = per[static_cast<std::size_t>(t)];
      for (int i = 0; i < per_thread; ++i) {
        const Case& c = cases[static_cast<std::size_t>(t * per_thread + i) % cases.size()];
        ComputeRequest req = c.batch.request(kGradient);
        req.request_id = std::to_string(t) + "/" + std::to_string(i);
        ComputeResult r;
        RpcStatus st;
        if (t % 2) {
          try {
            r = client.compute_async(req).get();
          } catch (const ClientError& e) {
            st = e.status();
          }
        } else {
          st = client.compute(req, r);
        }
        if (!st) {
          w.failures.push_back(req.request_id + ": " + st.to_string());
        } else if (::testing::AssertionResult eq = bitwise_equal(r, c.expected); !eq) {
          w.failures.push_back(req.request_id + ": " + eq.message());
        } else {
          w.most_attempts = std::max(w.most_attempts, r.timings().attempts);
          if (r.timings().attempts > 1) ++w.retried_results;
        }
        done.fetch_add(1);
      }
    });
  }
  for (std::thread& th : pool) th.join();
  Wave all;
  for (Wave& w : per) {
    all.failures.insert(all.failures.end(), w.failures.begin(), w.failures.end());
    all.most_attempts = std::max(all.most_attempts, w.most_attempts);
    all.retried_results += w.retried_results;
  }
  return all;
}

TEST(ServiceFailover, ThreeDaemonsShareTheLoadAndAKilledOneLosesNoRequest) {
  std::vector<std::unique_ptr<DaemonProcess>> daemons;
  std::vector<std::string> addresses;
  std::vector<int> ports;
  for (int i = 0; i < 3; ++i) {
    daemons.push_back(std::make_unique<DaemonProcess>(RBDGRADD_PATH, kConfig));
    addresses.push_back(daemons.back()->tcp_address());
    ports.push_back(metrics_port(*daemons.back()));
    ASSERT_GT(ports.back(), 0) << "no metrics address in the log:\n" << daemons.back()->log();
  }

  const Model model = load_embedded("iiwa14");
  std::vector<Case> cases;
  for (unsigned seed = 0; seed < 6; ++seed) {
    Batch b = random_batch("iiwa14", model.nv, 1 + 3 * seed, 900 + seed);
    auto expected = expected_outputs(model, b, kGradient, true);
    cases.push_back({std::move(b), std::move(expected)});
  }

  ClientOptions options;
  options.default_timeout = std::chrono::seconds(30);  // generous: a loaded 2-core machine
  options.retry.max_attempts = 6;                      // the default backoff, a little more patience
  const Client client(addresses, options);
  ASSERT_EQ(client.address().rfind("ipv4:", 0), 0u) << client.address();
  constexpr int kThreads = 4, kPerThread = 75;  // 300 requests a wave

  // wave 1: every daemon up; each serves a fair share
  std::atomic<int> done{0};
  const Wave first = run_wave(client, cases, kThreads, kPerThread, done);
  ASSERT_TRUE(first.failures.empty()) << first.failures.size() << " failed, first: " << first.failures.front();
  // (a daemon may count a request just after its answer left: read until all 300 show, or 10 s)
  double total = 0;
  std::vector<double> served;
  for (const auto until = Clock::now() + std::chrono::seconds(10); total < kThreads * kPerThread && Clock::now() < until;) {
    if (!served.empty()) std::this_thread::sleep_for(milliseconds(20));
    total = 0;
    served.clear();
    for (int port : ports) total += served.emplace_back(requests_answered(port));
  }
  EXPECT_EQ(total, kThreads * kPerThread);
  for (std::size_t i = 0; i < served.size(); ++i)
    EXPECT_GE(served[i], 0.15 * kThreads * kPerThread) << "daemon " << i << " served " << served[i] << " of " << total;

  // wave 2: daemon 1 freezes (SIGSTOP) once the wave runs, so that calls pile up on it, and is
  // killed (SIGKILL) when no call completes any more (every thread waits on it) or after 10 s
  done = 0;
  Wave second;
  std::thread wave([&] { second = run_wave(client, cases, kThreads, kPerThread, done); });
  while (done < 40) std::this_thread::sleep_for(milliseconds(1));
  DaemonProcess& victim = *daemons[1];
  EXPECT_EQ(::kill(victim.pid(), SIGSTOP), 0);
  int seen = done;
  auto still_since = Clock::now();
  for (const auto give_up = Clock::now() + std::chrono::seconds(10); Clock::now() < give_up;) {
    std::this_thread::sleep_for(milliseconds(20));
    if (done != seen) {
      seen = done;
      still_since = Clock::now();
    } else if (Clock::now() - still_since > milliseconds(300)) {
      break;
    }
  }
  const int done_at_kill = done;
  EXPECT_TRUE(victim.stop(SIGKILL).has_value());
  wave.join();

  EXPECT_TRUE(second.failures.empty()) << second.failures.size() << " of " << kThreads * kPerThread
                                       << " lost, first: " << second.failures.front();
  EXPECT_EQ(done, kThreads * kPerThread);
  EXPECT_LT(done_at_kill, kThreads * kPerThread) << "the kill came in the middle of the wave";
  const RetryStats stats = client.retry_stats();
  EXPECT_GE(stats.retries, 1u) << "the calls the killed daemon held were sent again";
  EXPECT_GE(second.retried_results, 1) << "results that needed more than one attempt";
  EXPECT_EQ(stats.gave_up, 0u);
  // the survivors answered the whole second wave between them (the killed one's share before it
  // froze is gone with it)
  const double survivors = requests_answered(ports[0]) + requests_answered(ports[2]) - served[0] - served[2];
  EXPECT_GE(survivors, kThreads * kPerThread - done_at_kill);
  std::printf("wave 1: the daemons served %.0f, %.0f and %.0f of %.0f requests\n", served[0], served[1], served[2], total);
  std::printf("failover: %d of %d calls done when daemon 1 was killed; %llu retries, %d results retried, "
              "at most %u attempts\n",
              done_at_kill, kThreads * kPerThread, static_cast<unsigned long long>(stats.retries),
              second.retried_results, second.most_attempts);
}

}  // namespace
}  // namespace rbdgrad::testing
