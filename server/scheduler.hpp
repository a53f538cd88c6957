// Routing of requests without a backend hint (issue 6), by a policy from the configuration:
// - cost (default): each backend that serves the model in an acceptable precision and can run the
//   request gets a predicted completion time, the wait for its pool (the predictions of the jobs
//   queued and running there) plus its latency model at this N; the earliest wins;
// - threshold: N <= small_n to the fpga, N >= large_n to cuda, the cpu in between (small_n and
//   large_n from the configuration, or where the latency models cross when not set).
// A hint pins the backend's kind (the plugin's own name: "cuda" is cuda0 and cuda1 of two GPUs;
// among several, the one predicted to finish first) or, naming one, the backend. An explicit precision is respected exactly (a request for f64 never
// lands on the fixed-point FPGA); PRECISION_AUTO takes each backend's best. The latency models
// come from calibration (calibration.hpp), kept in a CalibrationTable and its file.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <string_view>
#include <vector>

#include "backend_pool.hpp"
#include "calibration.hpp"
#include "calibration_table.hpp"
#include "config.hpp"
#include "model_registry.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

/// A request as the scheduler sees it.
struct RouteQuery {
  std::string_view backend;    // the hint: "" = by policy
  std::uint32_t precision = 0;  // one rbdgrad_precision flag, 0 = each backend's best
  std::uint32_t outputs = 0;    // rbdgrad_output flags
  std::uint64_t n = 0;          // states
  // backends that failed this request already (failover): never chosen again
  const std::vector<std::string>* exclude = nullptr;
};

/// One backend's predicted completion for a request, for GetServerInfo and the tests.
struct Prediction {
  std::string backend;
  std::uint32_t precision = 0;
  double wait_us = 0;     // the pool's predicted wait
  double compute_us = 0;  // the latency model at N
  bool has_model = false;
};

/// One backend's share of a request split across backends: states [first, first + n).
struct SplitPart {
  Route route;
  std::uint64_t first = 0;
  std::uint64_t n = 0;
  double wait_us = 0;     // predicted wait for its pool
  double compute_us = 0;  // its latency model at n
};

class Scheduler {
 public:
  Scheduler(const BackendPool& backends, const ModelRegistry& models, SchedulerConfig config);

  /// Fills the latency models: entries of the configured file whose fingerprints still hold are
  /// reused, the plugins' own models (the FPGA's cycle count) are taken as given, every other
  /// (backend, model, precision) is measured on its pool (calibration.hpp), and the file is
  /// rewritten when anything was measured. `remeasure` (Calibrate) measures even what the file
  /// holds, and also with calibrate "off". Each
  /// step is reported through `log` (a line each); failures there are logged and skipped: a
  /// backend without a model is routed to only when no backend has one.
  void calibrate(bool remeasure, const std::function<void(const std::string&)>& log);

  /// The same for one model, a scene being registered (scene_registrar.hpp): its latency models
  /// come the way the start-up's do (the file's while their fingerprints hold, the plugins' own,
  /// else measured on its pools unless calibrate is "off"), and are added to the others. Call it
  /// before the scene is published, while its pools are idle. Not concurrent with calibrate: each
  /// waits for the other.
  void calibrate_model(const ServedModel& model, const std::function<void(const std::string&)>& log);

  /// Chooses the backend (by the hint or the policy) and precision of a request, and the
  /// prediction of its compute time (0 without a model) and of its wait for an instance.
  /// Errors: BackendPool::route's; unavailable when every backend that could take the request is
  /// in query.exclude.
  Status route(const ServedModel& model, const RouteQuery& query, Route& out, double& predicted_us,
               double* predicted_wait_us = nullptr) const;

  /// The cost policy's split of a large request (config split_min_states) across the backends
  /// that run `precision`: the shares that finish together soonest by their latency models and
  /// queues, each a contiguous range of states, in load order. Empty (run it alone) when the
  /// request has a hint, is smaller than split_min_states, when fewer than two backends with a
  /// model can take it, or when the split is not predicted to finish at least 10% before
  /// `alone_us` (the chosen backend's predicted wait plus compute time): a margin for the
  /// models' error and the parts' own overheads.
  std::vector<SplitPart> split(const ServedModel& model, const RouteQuery& query, std::uint32_t precision,
                               double alone_us) const;

  /// Every backend's prediction for a request on `model` with automatic backend (the policy's
  /// candidates), in load order.
  std::vector<Prediction> predictions(const ServedModel& model, const RouteQuery& query) const;

  /// The limit of one backend call predicted to take `predicted_us` (0 = no prediction), in us,
  /// by scheduler.backend_timeout_ms: as configured, or max(1 s, 20x the prediction); 0 = none.
  double backend_timeout_us(double predicted_us) const noexcept;
  /// A backend whose call ran past its limit is suspect: routing (automatic, or a hint that names
  /// a kind of several backends) avoids it while another backend can take the request, until a
  /// call on it succeeds again (mark_healthy). Each returns whether the mark changed. Thread-safe.
  bool mark_suspect(const BackendState& backend) const noexcept;
  bool mark_healthy(const BackendState& backend) const noexcept;
  bool suspect(const BackendState& backend) const noexcept;

  /// The latency models (a copy: calibration may replace them).
  CalibrationTable table() const;
  const SchedulerConfig& config() const noexcept { return config_; }

  /// Where the fastest backend changes for `model` when each runs in its best precision (or in
  /// `precision` when set), up to max_n: "fpga until 24, cpu until 180, cuda" as data.
  std::vector<std::pair<std::uint64_t, std::string>> crossovers(const ServedModel& model, std::uint32_t precision,
                                                                 std::uint64_t max_n) const;

  /// The threshold policy's limits for `model`: the configured ones, else from crossovers (the
  /// last N the fpga is fastest, the first N cuda is). -1 where it does not apply.
  std::pair<std::int64_t, std::int64_t> thresholds(const ServedModel& model) const;

 private:
  struct Candidate {
    const BackendState* state = nullptr;
    std::uint32_t precision = 0;
    const InstancePool* pool = nullptr;
    const CalibrationEntry* entry = nullptr;  // under mutex_ (shared)
  };
  // the backends that could take the request, in load order (mutex_ held shared)
  std::vector<Candidate> candidates(const ServedModel& model, const RouteQuery& query) const;
  // the kind ("fpga", "cpu", "cuda") the threshold policy wants, when a candidate is of it, else ""
  std::string choose_by_threshold(const ServedModel& model, const std::vector<Candidate>& c, std::uint64_t n) const;
  // the candidate (of `kind`, "" = any) with a model predicted to finish first; "" when none has one
  std::string choose_by_cost(const std::vector<Candidate>& c, std::string_view kind, std::uint64_t n) const;
  // crossovers and thresholds with mutex_ already held
  std::vector<std::pair<std::uint64_t, std::string>> crossovers_locked(const ServedModel& model,
                                                                       std::uint32_t precision,
                                                                       std::uint64_t max_n) const;
  std::pair<std::int64_t, std::int64_t> thresholds_locked(const ServedModel& model) const;

  // one (backend, model, precision): the plugin's own model, the file's entry, or measured; false
  // (and why, logged) when there is none; `measured` set when it was timed
  bool calibrate_entry(const BackendState& backend, const ServedModel& model, std::uint32_t precision,
                       const CalibrationTable& file, bool remeasure, const std::function<void(const std::string&)>& log,
                       CalibrationEntry& entry, bool& measured) const;
  // config_.calibration_file's entries (none when unset or unreadable, said through `log`)
  CalibrationTable calibration_file(const std::function<void(const std::string&)>& log) const;
  // rewrites the file: its entries, replaced by `measured`'s
  void save_calibration(const CalibrationTable& file, const CalibrationTable& measured,
                        const std::function<void(const std::string&)>& log) const;

  // the flag of `backend` in suspect_, or null for a state that is not the pool's
  std::atomic<bool>* suspect_flag(const BackendState& backend) const noexcept;

  const BackendPool& backends_;
  const ModelRegistry& models_;
  const SchedulerConfig config_;
  // (backends_.backends()) the suspect marks, by index; lock-free for the request path
  std::unique_ptr<std::atomic<bool>[]> suspect_;
  std::mutex calibrating_;           // one calibration (calibrate, calibrate_model) at a time
  mutable std::shared_mutex mutex_;  // guards table_ (calibrate writes it, routing reads)
  CalibrationTable table_;
};

}  // namespace rbdgrad::server
