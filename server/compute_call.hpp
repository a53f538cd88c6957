// One ComputeRequest from acceptance to its serialized response, shared by the unary and the
// streaming handlers: parse, find the model, route, validate and convert (prepare, on the gRPC
// thread), then compute, fill the response with its timings and serialize it (run, on whichever
// thread the InstancePool gives it), then complete() hands it back to the handler.
// A fixed-point request whose states left the Q16.16 range runs a second time, on the fallback
// backend's pool, for those states only, in floating point; their outputs replace the flagged ones.
// A large automatically routed request may be split across backends (Scheduler::split): each
// share of its states runs on its backend's pool, and the last to finish completes the call.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/support/byte_buffer.h>

#include "backend_pool.hpp"
#include "config.hpp"
#include "instance_pool.hpp"
#include "metrics.hpp"
#include "model_registry.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"
#include "request_batch.hpp"
#include "scheduler.hpp"
#include "watchdog.hpp"

namespace rbdgrad::server {

class Coalescer;

// What every compute call needs from the service: read-only after start-up, except the
// admission counter.
class ComputeContext {
 public:
  /// \param fixed_point_fallback the backend that recomputes fixed-point states that left the
  ///        format's range (ServerConfig::fixed_point_fallback); "" = none.
  /// `metrics` (may be null) records every request's outcome; `coalescer` (may be null) batches
  /// small concurrent requests.
  ComputeContext(const ModelRegistry& models, const BackendPool& backends, const Scheduler& scheduler,
                 const LimitsConfig& limits, std::string fixed_point_fallback = "", Metrics* metrics = nullptr,
                 Coalescer* coalescer = nullptr)
      : models_(models),
        backends_(backends),
        scheduler_(scheduler),
        limits_(limits),
        fixed_point_fallback_(std::move(fixed_point_fallback)),
        metrics_(metrics),
        coalescer_(coalescer),
        watchdog_(make_watchdog(scheduler)) {}

  const ModelRegistry& models() const noexcept { return models_; }
  const BackendPool& backends() const noexcept { return backends_; }
  const Scheduler& scheduler() const noexcept { return scheduler_; }
  Metrics* metrics() const noexcept { return metrics_; }
  Coalescer* coalescer() const noexcept { return coalescer_; }
  /// Bounds backend calls (scheduler.backend_timeout_ms); null when that is 0 (off).
  Watchdog* watchdog() const noexcept { return watchdog_.get(); }
  const LimitsConfig& limits() const noexcept { return limits_; }
  const std::string& fixed_point_fallback() const noexcept { return fixed_point_fallback_; }

  enum class Admission { kAdmitted, kTooManyInFlight, kShuttingDown };

  /// Counts one more request in flight, unless max_concurrent_requests are already in flight or
  /// the daemon is stopping (then nothing is counted). Every kAdmitted must be matched by one
  /// release(), once the response has gone out.
  Admission admit() noexcept;
  void release() noexcept { in_flight_.fetch_sub(1, std::memory_order_relaxed); }
  std::int64_t in_flight() const noexcept { return in_flight_.load(std::memory_order_relaxed); }

  /// From now on admit() refuses every request with kShuttingDown.
  void begin_shutdown() noexcept { stopping_.store(true, std::memory_order_relaxed); }

 private:
  const ModelRegistry& models_;
  const BackendPool& backends_;
  const Scheduler& scheduler_;
  const LimitsConfig limits_;
  const std::string fixed_point_fallback_;
  static std::unique_ptr<Watchdog> make_watchdog(const Scheduler& scheduler);

  Metrics* const metrics_;
  Coalescer* const coalescer_;
  const std::unique_ptr<Watchdog> watchdog_;
  std::atomic<std::int64_t> in_flight_{0};
  std::atomic<bool> stopping_{false};
};

/// The message of a request refused because the daemon is stopping.
inline constexpr const char* kShuttingDownMessage = "rbdgradd is shutting down";

class ComputeCall : public PoolJob {
 public:
  using Clock = std::chrono::steady_clock;

  /// \param accepted when the request was received: the start of queue_us and total_us.
  /// \param response_bytes where run() serializes the response; must outlive complete().
  ComputeCall(Clock::time_point accepted, grpc::ByteBuffer* response_bytes)
      : accepted_(accepted), response_bytes_(response_bytes) {}
  ComputeCall(const ComputeCall&) = delete;
  ComputeCall& operator=(const ComputeCall&) = delete;

  /// Parses `message` as a ComputeRequest and readies the job: model lookup (not_found naming the
  /// loaded models), backend and precision (BackendPool::route), the inputs (RequestBatch), the
  /// backend's can_run. Every error names the request: "request 'id': ...", or, for a request
  /// without an id on a stream, "stream message 3: ...". `stream_index` < 0 for a unary call.
  /// A message that does not parse is invalid_argument "malformed ComputeRequest (12 bytes)".
  /// Nothing is kept on error: the call is then not to be submitted.
  /// `deadline` (the call's gRPC deadline; max = none): a request whose predicted wait and compute
  /// time (Scheduler::route) would not fit before it is refused deadline_exceeded, naming both.
  Status prepare(const grpc::ByteBuffer& message, const ComputeContext& context, std::int64_t stream_index,
                 Clock::time_point deadline = Clock::time_point::max());

  /// Hands a prepared call to its backend's pool: run() then happens once, maybe before submit()
  /// returns, and again on another pool when fixed-point states fall back or when an
  /// automatically routed request's backend fails as a whole (UNAVAILABLE or INTERNAL: failover
  /// to the next best backend); complete() once at the end.
  /// A split call hands each share to its backend's pool instead; when a share fails, the whole
  /// request runs again unsplit (failover when that backend failed as a whole, else on that
  /// backend, whose error then numbers the failed state within the request).
  /// With dynamic batching (ComputeContext::coalescer) a small request first waits for others to
  /// share its backend call (finish_in_group).
  void submit();

  // For the Coalescer: the prepared batch, its pool and prediction.
  const rbdgrad_batch& prepared_batch() const noexcept { return batch_.batch(); }
  int nv() const noexcept { return batch_.nv(); }
  InstancePool* pool() const noexcept { return route_.pool; }
  double predicted_us() const noexcept { return predicted_us_; }
  /// The group's backend call (`group`) held this call's states at
  /// [first, first + n): takes its outputs and completes. When one of this call's states failed
  /// (every state, when the group call failed as a whole), computes it again alone on `instance`
  /// instead (the usual path: exact messages, failover, fallback). `group_states` > 0 for one
  /// member only: the group's size, for the metrics.
  void finish_in_group(PluginInstance& instance, const rbdgrad_batch& group, std::uint64_t first,
                       Clock::time_point started, Clock::duration compute, std::size_t group_requests,
                       std::uint64_t group_states) noexcept;

  /// Counts a request that prepare() refused (the handler answers it) in the metrics.
  void record_refusal(const Status& refusal) const;

  /// The outcome, valid once complete() is called: ok (and the response serialized into
  /// response_bytes) or the error, with the backend's code and a message naming the request.
  const Status& status() const noexcept { return status_; }

  /// The watchdog's word that `attempt`'s backend call ran past its limit: the backend becomes
  /// suspect (log, rbdgrad_backend_timeouts_total) and, when another backend can take the request
  /// (the next best by the scheduler, of the hint's kind when it has one), the request runs there
  /// and the late result is dropped; else the call goes on and its result stands.
  static void expired(const std::shared_ptr<CallAttempt>& attempt) noexcept;

 protected:
  virtual ~ComputeCall() = default;

  /// Called once, at the end of run(), on the thread that ran it. The call may be deleted here:
  /// nothing touches it afterwards.
  virtual void complete() noexcept = 0;

 private:
  // One backend's share of a split call: states [part.first, part.first + part.n) of batch_.
  class PartJob final : public PoolJob {
   public:
    void run(PluginInstance& instance) noexcept override;
    ComputeCall* call = nullptr;
    SplitPart part;
    rbdgrad_batch batch{};  // the share's view of batch_ (plugin::states_of)
    Status status;
    Clock::time_point started{};
    Clock::duration compute{};
  };

  void run(PluginInstance& instance) noexcept final;
  // Runs `step` (true: the call is answered; false: it goes on elsewhere, which concludes it),
  // then records and completes an answered call; what `step` throws is the call's internal error.
  template <class Step>
  void conclude(Step&& step) noexcept;
  // A share has run: the last one finishes the call, or runs it again unsplit when one failed.
  void part_done() noexcept;
  // After share `failed` failed: the whole request again, alone (true), or the failure stands.
  bool rerun_unsplit(const PartJob& failed);
  bool split() const noexcept { return !parts_.empty() && !unsplit_; }
  // the body of run() that may throw; false when the call goes on to its fallback run, or
  // elsewhere after a timeout. `watched`: the backend call is bounded by the watchdog.
  bool run_stage(PluginInstance& instance, bool watched = false);
  // Computes batch_ on `instance` into `computed` (under the watchdog when `watched` and a limit
  // applies). false: the call ran past its limit and the request went elsewhere: it may be gone
  // already, so nothing of it may be touched.
  bool compute_batch(PluginInstance& instance, bool watched, Status& computed);
  // The states to submit the primary run as: more than any inline limit when it must not run on
  // the submitting thread (a bounded call on a device backend), else the batch's.
  std::uint64_t inline_states() const noexcept;
  // On the watchdog's thread, while the backend call runs: readies the request for the next
  // backend (true), its buffers handed to `attempt`; false when no other backend can take it.
  bool take_over(CallAttempt& attempt);
  // On the computing thread, after the watchdog took the request away: only `attempt` is touched.
  static void late_result(CallAttempt& attempt, const Status& computed) noexcept;
  // After the primary run failed with `failure`: when it was routed automatically and the backend
  // failed as a whole, routes it to the next best backend and readies batch_ for it (true); when
  // no backend is left, says so in `failure` (false).
  bool prepare_failover(Status& failure);
  // After the primary run failed with `failure`: when the request is fixed-point, a fallback
  // backend is configured and every failed state left the range, readies fallback_batch_ with
  // those states and returns true; otherwise false (the failure stands) or an error of its own.
  Status prepare_fallback(const Status& failure, bool& prepared);
  // The response from batch_ (and fallback_batch_), with timings, serialized into response_bytes_.
  void finish();
  // the outcome (status_) into the metrics, if any
  void record() const;

  const Clock::time_point accepted_;
  grpc::ByteBuffer* const response_bytes_;
  const ComputeContext* context_ = nullptr;  // set by prepare
  const ServedModel* model_ = nullptr;
  std::string prefix_;  // "request 'id': " for messages
  rbdgrad::v1::ComputeRequest request_;
  rbdgrad::v1::ComputeResponse response_;
  RequestBatch batch_;
  Route route_;
  double predicted_us_ = 0;  // the scheduler's prediction of the primary run's compute time
  Clock::time_point deadline_ = Clock::time_point::max();
  std::string hint_;                    // the request's backend hint: "" = routed by the scheduler
  std::vector<std::string> failed_;     // backends that failed it as a whole (failover), in order
  std::vector<std::string> failovers_;  // "cuda: device lost" for each, for the response
  std::size_t batch_requests_ = 1;      // requests of its backend call (dynamic batching)
  std::uint64_t batch_states_ = 0;      // that call's states, for the metrics (0: another member counts it)
  Status status_;
  Clock::duration compute_time_{};  // in the backends, both runs
  Clock::time_point started_;       // of the primary run
  // the fallback run: the states of batch_ it recomputes (ascending), their batch and backend
  bool in_fallback_ = false;
  std::vector<std::uint32_t> fallback_states_;
  RequestBatch fallback_batch_;
  Route fallback_route_;
  // a split call's shares (sized once, in prepare); unsplit_ once a failed share made it run whole
  std::vector<PartJob> parts_;
  std::atomic<std::size_t> parts_left_{0};
  bool unsplit_ = false;
};

}  // namespace rbdgrad::server
