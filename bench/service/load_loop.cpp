// The measuring loops of service_load (see load_loop.hpp).
#include "load_loop.hpp"

#include <algorithm>
#include <atomic>
#include <barrier>
#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace rbdgrad::bench {
namespace {

using Clock = std::chrono::steady_clock;

double micros(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

std::optional<Clock::time_point> deadline_after(Clock::time_point start, double duration_s) {
  if (duration_s <= 0) return std::nullopt;
  return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(duration_s));
}

// the first error of several threads, and a flag that tells the others to stop
class FirstError {
 public:
  void set(Status s) {
    std::lock_guard lock(mutex_);
    if (status_.is_ok()) status_ = std::move(s);
    failed_.store(true, std::memory_order_relaxed);
  }
  bool failed() const { return failed_.load(std::memory_order_relaxed); }
  Status get() {
    std::lock_guard lock(mutex_);
    return status_;
  }

 private:
  std::mutex mutex_;
  Status status_;
  std::atomic<bool> failed_{false};
};

}  // namespace

Status run_callers(const std::function<std::unique_ptr<Caller>()>& make_caller, const LoadPlan& plan, LoadResult& out) {
  const unsigned k = std::max(1u, plan.concurrency);
  const std::uint64_t share = (plan.requests + k - 1) / k;
  std::vector<std::vector<double>> samples(k);
  std::vector<std::vector<ServerTimings>> server(k);
  std::vector<Clock::time_point> ends(k);
  Clock::time_point start;
  FirstError error;
  // every caller warms up, then all start timing together; the completion step takes the start time
  std::barrier sync(static_cast<std::ptrdiff_t>(k), [&]() noexcept { start = Clock::now(); });

  const auto body = [&](unsigned i) {
    std::unique_ptr<Caller> caller = make_caller();
    std::vector<double>& mine = samples[i];
    mine.reserve(share);
    server[i].reserve(share);
    for (std::uint64_t w = 0; w < plan.warmup && !error.failed(); ++w) {
      Status s = caller->call();
      if (s) s = caller->check();
      if (!s) error.set(std::move(s));
    }
    sync.arrive_and_wait();
    const std::optional<Clock::time_point> deadline = deadline_after(start, plan.duration_s);
    for (std::uint64_t r = 0; r < share && !error.failed(); ++r) {
      const Clock::time_point t0 = Clock::now();
      Status s = caller->call();
      const Clock::time_point t1 = Clock::now();
      if (s) s = caller->check();
      if (!s) {
        error.set(std::move(s));
        break;
      }
      mine.push_back(micros(t0, t1));
      if (ServerTimings st; caller->server_timings(st)) server[i].push_back(st);
      if (deadline && t1 >= *deadline) break;
    }
    ends[i] = Clock::now();
    if (Status s = caller->finish(); !s && !error.failed()) error.set(std::move(s));
  };

  std::vector<std::thread> threads;
  for (unsigned i = 1; i < k; ++i) threads.emplace_back(body, i);
  body(0);
  for (std::thread& t : threads) t.join();
  if (error.failed()) return error.get();

  std::vector<double> all;
  for (const std::vector<double>& s : samples) all.insert(all.end(), s.begin(), s.end());
  out.wall_s = micros(start, *std::max_element(ends.begin(), ends.end())) * 1e-6;
  out.latency = summarize(all);
  out.requests_per_s = out.wall_s > 0 ? static_cast<double>(out.latency.count) / out.wall_s : 0;
  std::vector<double> queue, compute, total;
  for (const std::vector<ServerTimings>& per_caller : server)
    for (const ServerTimings& t : per_caller) {
      queue.push_back(t.queue_us);
      compute.push_back(t.compute_us);
      total.push_back(t.total_us);
    }
  out.server_queue = summarize(queue);
  out.server_compute = summarize(compute);
  out.server_total = summarize(total);
  return Status::ok();
}

Status run_in_process(InProcessCompute& compute, const v1::ComputeRequest& request, rbdgrad_precision precision,
                      const LoadPlan& plan, const std::function<Status(const v1::ComputeResponse&)>& check,
                      InProcessResult& out) {
  v1::ComputeResponse response;
  for (std::uint64_t w = 0; w < plan.warmup; ++w) {
    if (Status s = compute.run(request, precision, response); !s) return s;
    if (Status s = check(response); !s) return s;
  }

  // the daemon's path, step by step
  std::vector<double> total, from_request, compute_us, to_response;
  for (auto* v : {&total, &from_request, &compute_us, &to_response}) v->reserve(plan.requests);
  const Clock::time_point start = Clock::now();
  const std::optional<Clock::time_point> deadline = deadline_after(start, plan.duration_s);
  Clock::time_point end = start;
  const auto idle = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::micro>(plan.idle_us));
  for (std::uint64_t r = 0; r < plan.requests; ++r) {
    if (plan.idle_us > 0) std::this_thread::sleep_for(idle);
    StageTimes t;
    const Clock::time_point t0 = Clock::now();
    if (Status s = compute.run(request, precision, response, &t); !s) return s;
    end = Clock::now();
    if (Status s = check(response); !s) return s;
    total.push_back(micros(t0, end));
    from_request.push_back(t.from_request_us);
    compute_us.push_back(t.compute_us);
    to_response.push_back(t.to_response_us);
    if (deadline && end >= *deadline) break;
  }
  out.total.wall_s = micros(start, end) * 1e-6;
  out.total.latency = summarize(total);
  out.total.requests_per_s = out.total.wall_s > 0 ? static_cast<double>(out.total.latency.count) / out.total.wall_s : 0;
  out.from_request = summarize(from_request);
  out.compute = summarize(compute_us);
  out.to_response = summarize(to_response);
  const std::size_t count = total.size();  // the other loops make as many samples

  // compute alone: the batch converted once, outputs left in its buffers
  server::RequestBatch batch;
  if (Status s = compute.prepare(request, precision, batch); !s) return s;
  std::vector<double> alone;
  alone.reserve(count);
  for (std::size_t r = 0; r < count; ++r) {
    if (plan.idle_us > 0) std::this_thread::sleep_for(idle);
    const Clock::time_point t0 = Clock::now();
    if (Status s = compute.compute(batch); !s) return s;
    alone.push_back(micros(t0, Clock::now()));
  }
  out.compute_alone = summarize(alone);

  // what both ends' protobuf code adds to a round trip: client serialises the request, server parses
  // it, server serialises the response, client parses it
  std::string request_wire, response_wire;
  v1::ComputeRequest parsed_request;
  v1::ComputeResponse parsed_response;
  std::vector<double> marshal;
  marshal.reserve(count);
  for (std::size_t r = 0; r < count; ++r) {
    const Clock::time_point t0 = Clock::now();
    const bool ok = request.SerializeToString(&request_wire) && parsed_request.ParseFromString(request_wire) &&
                    response.SerializeToString(&response_wire) && parsed_response.ParseFromString(response_wire);
    marshal.push_back(micros(t0, Clock::now()));
    if (!ok) return Status(StatusCode::kInternal, "protobuf serialisation round trip failed");
  }
  out.marshal = summarize(marshal);
  return Status::ok();
}

}  // namespace rbdgrad::bench
