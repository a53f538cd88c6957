// The soak test of issue 9: K clients for T seconds send a mix of valid and invalid requests to
// rbdgradd on loopback, while a fault-injecting backend (fault_plugin.cpp: errors, slow calls,
// hangs) takes part of the load; optionally against three replicas, one of which is killed
// (SIGKILL) midway and started again on its port. Reports requests sent and answered, outcomes
// by kind, lost requests (must be 0), latency percentiles and the daemons' memory over time.
//
//   soak [--clients K] [--seconds T] [--replicas 1|3] [--kill-at S] [--restart-after S]
//
// Valid requests (80%): iiwa14, N from 1 to 64, f64 tau input, d qdd/d q and d qdd/d qd; the
// answer must hold N finite matrices of 7 x 7. Invalid (20%): a q of the wrong size, an unknown
// model, N = 0, a NaN in q (the state fails alone: FAILED_PRECONDITION or an answer with its
// state marked, as the daemon reports it). A request is lost when no answer came: a deadline
// exceeded, or UNAVAILABLE after the client's retries; every other status is an answer.
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "../../tests/integration/daemon_process.hpp"
#include "rbdgrad/client.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using rbdgrad::testing::DaemonProcess;

struct Options {
  int clients = 8;
  double seconds = 60;
  int replicas = 1;
  double kill_at = -1;        // seconds into the run; < 0: no kill
  double restart_after = 2;   // seconds after the kill
};

// The daemon's configuration: iiwa14, the CPU backend, and the fault plugin taking the batches of
// 32 states and more (threshold policy), calibration off (the faults would distort it), a call
// past 300 ms re-run on the CPU (scheduler.backend_timeout_ms). The
// listen address comes from DaemonProcess's flags.
std::string config() {
  return "models: [{name: iiwa14, embedded: iiwa14}]\n"
         "workers: 2\n"
         "scheduler: {policy: threshold, small_n: 0, large_n: 32, calibrate: \"off\", backend_timeout_ms: 300}\n"
         "plugins:\n"
         "  - path: " RBDGRAD_FAULT_PLUGIN_PATH "\n"
         "    options: {inner: " RBDGRAD_CPU_PLUGIN_PATH ", threads: \"1\", error_permille: \"20\", "
         "slow_permille: \"30\", slow_ms: \"40\", hang_permille: \"5\", hang_ms: \"1500\"}\n";
}

// resident memory of a process, KiB (0 when it is gone)
long rss_kib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  return 0;
}

struct Tally {
  std::mutex mutex;
  std::map<std::string, long> outcomes;  // "ok", "invalid:INVALID_ARGUMENT", "valid:UNAVAILABLE", ...
  long sent = 0, answered = 0, lost = 0, wrong = 0;
  std::vector<double> latency_us;  // valid requests answered with a result
  void add(const std::string& outcome, bool answer, bool is_lost, double us, bool with_result) {
    std::lock_guard lock(mutex);
    ++sent;
    ++outcomes[outcome];
    answered += answer;
    lost += is_lost;
    if (with_result) latency_us.push_back(us);
  }
};

void client_loop(const rbdgrad::Client& client, int id, Clock::time_point end, Tally& tally) {
  std::mt19937 rng(1000 + id);
  std::uniform_real_distribution<double> unit(-1, 1);
  constexpr int nv = 7;
  while (Clock::now() < end) {
    const int kind = std::uniform_int_distribution<int>(0, 99)(rng);
    const std::uint32_t n = std::uniform_int_distribution<std::uint32_t>(1, 64)(rng);
    std::vector<double> q(n * nv), qd(n * nv), tau(n * nv);
    for (std::size_t e = 0; e < q.size(); ++e) q[e] = unit(rng), qd[e] = unit(rng), tau[e] = unit(rng);
    rbdgrad::ComputeRequest req;
    req.model = "iiwa14";
    req.num_states = n;
    req.precision = rbdgrad::Precision::kF64;
    req.input = rbdgrad::ComputeInput::kTau;
    req.outputs = rbdgrad::Output::kDqddDq | rbdgrad::Output::kDqddDqd;
    req.timeout = std::chrono::seconds(20);
    bool valid = true;
    if (kind >= 80) {
      valid = false;
      if (kind < 85) q.pop_back();                   // q of the wrong size
      else if (kind < 90) req.model = "no_such_robot";  // unknown model
      else if (kind < 95) req.num_states = 0;         // no states
      else q[0] = std::nan("");                       // a state that cannot be computed
    }
    req.q = q;
    req.qd = qd;
    req.u = tau;
    rbdgrad::ComputeResult result;
    const auto start = Clock::now();
    const rbdgrad::RpcStatus s = client.compute(req, result);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
    const bool lost = s.code() == rbdgrad::RpcCode::kDeadlineExceeded || s.code() == rbdgrad::RpcCode::kUnavailable;
    std::string outcome = std::string(valid ? "valid:" : "invalid:") + (s.is_ok() ? "OK" : rbdgrad::rpc_code_name(s.code()));
    bool with_result = false;
    if (valid && s.is_ok()) {
      // the answer must be whole: N matrices, finite
      bool whole = result.num_states() == n;
      for (std::uint32_t k = 0; whole && k < n; ++k) whole = result.dqdd_dq(k).allFinite() && result.dqdd_dqd(k).allFinite();
      if (!whole) outcome = "valid:WRONG_ANSWER";
      with_result = whole;
    }
    tally.add(outcome, !lost, lost, us, with_result);
  }
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const double value = std::atof(argv[i + 1]);
    if (flag == "--clients") o.clients = static_cast<int>(value);
    else if (flag == "--seconds") o.seconds = value;
    else if (flag == "--replicas") o.replicas = static_cast<int>(value);
    else if (flag == "--kill-at") o.kill_at = value;
    else if (flag == "--restart-after") o.restart_after = value;
    else {
      std::fprintf(stderr, "usage: soak [--clients K] [--seconds T] [--replicas N] [--kill-at S] [--restart-after S]\n");
      return 2;
    }
  }
  std::vector<std::unique_ptr<DaemonProcess>> daemons;
  std::vector<std::string> addresses;
  for (int r = 0; r < o.replicas; ++r) {
    // an ephemeral port (DaemonProcess's --listen 127.0.0.1:0): a restarted replica comes back on it
    daemons.push_back(std::make_unique<DaemonProcess>(RBDGRAD_DAEMON_PATH, config()));
    addresses.push_back(daemons.back()->tcp_address());
  }
  char kill_text[96] = "";
  if (o.kill_at >= 0)
    std::snprintf(kill_text, sizeof kill_text, ", replica 0 killed at %.0f s and started again %.0f s later", o.kill_at,
                  o.restart_after);
  std::printf("soak: %d clients, %.0f s, %d replica(s)%s\n", o.clients, o.seconds, o.replicas, kill_text);
  rbdgrad::Client client = o.replicas == 1 ? rbdgrad::Client(addresses[0]) : rbdgrad::Client(addresses);
  // warm-up, then the memory baseline
  {
    Tally warm;
    client_loop(client, -1, Clock::now() + std::chrono::seconds(2), warm);
  }
  std::vector<long> rss_start;
  for (auto& d : daemons) rss_start.push_back(rss_kib(d->pid()));

  Tally tally;
  const auto begin = Clock::now();
  const auto end = begin + std::chrono::milliseconds(static_cast<long>(o.seconds * 1000));
  std::vector<std::thread> threads;
  for (int c = 0; c < o.clients; ++c) threads.emplace_back(client_loop, std::cref(client), c, end, std::ref(tally));
  // memory every 5 s; the kill and the restart when asked
  bool killed = false, restarted = o.kill_at < 0;
  std::vector<std::vector<long>> rss_samples(daemons.size());
  auto next_sample = begin;
  while (Clock::now() < end) {
    const double t = std::chrono::duration<double>(Clock::now() - begin).count();
    if (!killed && o.kill_at >= 0 && t >= o.kill_at) {
      daemons[0]->stop(SIGKILL);
      killed = true;
      std::printf("t = %.1f s: replica 0 killed\n", t);
    }
    if (killed && !restarted && t >= o.kill_at + o.restart_after) {
      daemons[0] = std::make_unique<DaemonProcess>(RBDGRAD_DAEMON_PATH, config(),
                                                   std::vector<std::string>{"--listen", addresses[0]});
      restarted = true;
      std::printf("t = %.1f s: replica 0 started again on %s\n", t, addresses[0].c_str());
    }
    if (Clock::now() >= next_sample) {
      for (std::size_t d = 0; d < daemons.size(); ++d) rss_samples[d].push_back(rss_kib(daemons[d]->pid()));
      next_sample += std::chrono::seconds(5);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  for (std::thread& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - begin).count();

  std::printf("\nrequests sent %ld, answered %ld, lost %ld, in %.1f s (%.0f per s)\n", tally.sent, tally.answered,
              tally.lost, elapsed, static_cast<double>(tally.sent) / elapsed);
  std::printf("outcomes:\n");
  for (const auto& [outcome, count] : tally.outcomes) std::printf("  %-36s %ld\n", outcome.c_str(), count);
  std::printf("latency of valid requests answered with a result: p50 %.0f us, p99 %.0f us, p99.9 %.0f us, max %.0f us\n",
              percentile(tally.latency_us, 0.5), percentile(tally.latency_us, 0.99),
              percentile(tally.latency_us, 0.999), percentile(tally.latency_us, 1.0));
  const rbdgrad::RetryStats retries = client.retry_stats();
  std::printf("client retries %llu, calls given up %llu\n", static_cast<unsigned long long>(retries.retries),
              static_cast<unsigned long long>(retries.gave_up));
  for (std::size_t d = 0; d < daemons.size(); ++d) {
    std::printf("replica %zu memory (VmRSS, MiB): after warm-up %.1f; every 5 s:", d, rss_start[d] / 1024.0);
    for (long kib : rss_samples[d]) std::printf(" %.1f", kib / 1024.0);
    std::printf("%s\n", d == 0 && o.kill_at >= 0 ? " (restarted midway)" : "");
  }
  return tally.lost == 0 ? 0 : 1;
}
