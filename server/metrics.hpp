// The daemon's metrics in Prometheus' text format, served over HTTP at /metrics (prometheus-cpp,
// Debian's prometheus-cpp-dev): per backend, the requests by outcome, the states computed, the
// failovers and fixed-point fallbacks; histograms of queue, compute and total time and of batch
// sizes; and, read at each scrape, the requests in flight and each pool's queue. A backend that
// stands in for another says so in a mode label ("csim").
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rbdgrad/status.hpp"

namespace prometheus {
class Exposer;
class Registry;
class Collectable;
template <typename T>
class Family;
class Counter;
class Histogram;
}  // namespace prometheus

namespace rbdgrad::server {

/// One finished request (answered or refused), for Metrics::record.
struct RequestRecord {
  std::string_view backend;    // the backend that ran it last; "" when refused before routing
  std::string_view mode;       // the backend's mode ("csim"), "" as itself
  std::string_view model;      // "" when the model was unknown
  std::string_view precision;  // "f64", "f32", "fixed"; "" when refused before routing
  StatusCode code = StatusCode::kOk;
  std::uint64_t states = 0;          // the request's N
  double queue_seconds = -1;         // accepted -> computation started; < 0 = never started
  double compute_seconds = -1;       // in the backends; < 0 = never computed
  double total_seconds = 0;          // accepted -> answered
  std::vector<std::string> failed_backends;  // failovers: the backends that failed it first
  std::uint64_t fallback_states = 0;         // fixed-point states computed again in floating point
  std::uint64_t batch_states = 0;  // the states of its backend call, once per call (0: counted with
                                   // another request of the same coalesced call, or never computed)
  // A request split across backends: each share, counted in states and batch sizes by its own
  // backend (instead of `backend` and batch_states). Empty when not split.
  struct Part {
    std::string_view backend, mode;
    std::uint64_t states = 0;
  };
  std::vector<Part> parts;
};

/// A queue's state at scrape time.
struct QueueSample {
  std::string backend, model;
  std::uint64_t queued = 0, running = 0;
  double pending_seconds = 0;
};

class Metrics {
 public:
  /// `listen` "host:port" serves /metrics over HTTP ("127.0.0.1:0" picks a port); "" records
  /// without serving. `queues` and `in_flight` are called at each scrape.
  /// Errors: unavailable when the address cannot be bound.
  static Status create(const std::string& listen, std::function<std::vector<QueueSample>()> queues,
                       std::function<std::int64_t()> in_flight, std::unique_ptr<Metrics>& out);
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  /// Thread-safe; a few label lookups and atomic adds.
  void record(const RequestRecord& r);
  /// A call refused before it was looked at, by `reason`: "unauthenticated" (no valid token),
  /// "client_rate", "client_concurrency" (the per-client limits), "max_concurrent_requests".
  void record_rejection(std::string_view reason);
  /// A backend call that ran past scheduler.backend_timeout_ms (rbdgrad_backend_timeouts_total).
  void record_timeout(std::string_view backend);

  /// The bound HTTP port; 0 when not serving.
  int port() const noexcept { return port_; }
  /// The text a scrape returns (the tests and `rbdgradd --once` read it without HTTP).
  std::string text() const;

 private:
  Metrics() = default;

  std::shared_ptr<prometheus::Registry> registry_;
  std::shared_ptr<prometheus::Collectable> live_;  // queues and in-flight, read at scrape
  std::unique_ptr<prometheus::Exposer> exposer_;
  int port_ = 0;
  prometheus::Family<prometheus::Counter>* requests_ = nullptr;
  prometheus::Family<prometheus::Counter>* states_ = nullptr;
  prometheus::Family<prometheus::Counter>* failovers_ = nullptr;
  prometheus::Family<prometheus::Counter>* fallback_states_ = nullptr;
  prometheus::Family<prometheus::Counter>* rejected_ = nullptr;
  prometheus::Family<prometheus::Counter>* timeouts_ = nullptr;
  prometheus::Counter* split_requests_ = nullptr;
  prometheus::Family<prometheus::Histogram>* queue_ = nullptr;
  prometheus::Family<prometheus::Histogram>* compute_ = nullptr;
  prometheus::Family<prometheus::Histogram>* total_ = nullptr;
  prometheus::Family<prometheus::Histogram>* batch_states_ = nullptr;
};

}  // namespace rbdgrad::server
