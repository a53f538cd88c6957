#include "metrics.hpp"

#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/exposer.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <exception>
#include <utility>

namespace rbdgrad::server {

namespace {

// 10 us to about 10 s, a factor of 2 apart: a CPU gradient of one state to a large GPU batch
prometheus::Histogram::BucketBoundaries time_buckets() {
  prometheus::Histogram::BucketBoundaries b;
  for (double t = 10e-6; t < 20; t *= 2) b.push_back(t);
  return b;
}
// 1 to 65536 states, powers of 2
prometheus::Histogram::BucketBoundaries size_buckets() {
  prometheus::Histogram::BucketBoundaries b;
  for (double n = 1; n <= 65536; n *= 2) b.push_back(n);
  return b;
}

std::string label(std::string_view value) { return value.empty() ? "none" : std::string(value); }

// The gauges read at scrape time.
class LiveState : public prometheus::Collectable {
 public:
  LiveState(std::function<std::vector<QueueSample>()> queues, std::function<std::int64_t()> in_flight)
      : queues_(std::move(queues)), in_flight_(std::move(in_flight)) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    prometheus::MetricFamily in_flight{"rbdgrad_requests_in_flight", "Compute requests accepted and not yet answered",
                                       prometheus::MetricType::Gauge, {}};
    prometheus::ClientMetric m;
    m.gauge.value = in_flight_ ? static_cast<double>(in_flight_()) : 0;
    in_flight.metric.push_back(m);
    prometheus::MetricFamily queued{"rbdgrad_queue_requests",
                                    "Requests of one backend and model waiting for an instance or running",
                                    prometheus::MetricType::Gauge, {}};
    prometheus::MetricFamily pending{"rbdgrad_queue_pending_seconds",
                                     "The scheduler's predicted compute time of those requests",
                                     prometheus::MetricType::Gauge, {}};
    for (const QueueSample& q : queues_ ? queues_() : std::vector<QueueSample>{}) {
      for (const auto& [state, value] : {std::pair{"queued", q.queued}, std::pair{"running", q.running}}) {
        prometheus::ClientMetric c;
        c.label = {{"backend", q.backend}, {"model", q.model}, {"state", state}};
        c.gauge.value = static_cast<double>(value);
        queued.metric.push_back(c);
      }
      prometheus::ClientMetric p;
      p.label = {{"backend", q.backend}, {"model", q.model}};
      p.gauge.value = q.pending_seconds;
      pending.metric.push_back(p);
    }
    return {in_flight, queued, pending};
  }

 private:
  std::function<std::vector<QueueSample>()> queues_;
  std::function<std::int64_t()> in_flight_;
};

}  // namespace

Status Metrics::create(const std::string& listen, std::function<std::vector<QueueSample>()> queues,
                       std::function<std::int64_t()> in_flight, std::unique_ptr<Metrics>& out) {
  std::unique_ptr<Metrics> m(new Metrics());
  m->registry_ = std::make_shared<prometheus::Registry>();
  prometheus::Registry& r = *m->registry_;
  m->requests_ = &prometheus::BuildCounter()
                      .Name("rbdgrad_requests_total")
                      .Help("Compute requests answered, by the backend that ran them last and the outcome")
                      .Register(r);
  m->states_ = &prometheus::BuildCounter()
                    .Name("rbdgrad_states_total")
                    .Help("States of the requests answered without error")
                    .Register(r);
  m->failovers_ = &prometheus::BuildCounter()
                       .Name("rbdgrad_failovers_total")
                       .Help("Requests a backend failed as a whole and another one ran")
                       .Register(r);
  m->timeouts_ = &prometheus::BuildCounter()
                      .Name("rbdgrad_backend_timeouts_total")
                      .Help("Backend calls that ran past scheduler.backend_timeout_ms (the backend is then suspect)")
                      .Register(r);
  m->split_requests_ = &prometheus::BuildCounter()
                            .Name("rbdgrad_split_requests_total")
                            .Help("Requests split across backends (scheduler.split_min_states)")
                            .Register(r)
                            .Add({});
  m->fallback_states_ = &prometheus::BuildCounter()
                             .Name("rbdgrad_fixed_point_fallback_states_total")
                             .Help("Fixed-point states that left the format's range and were computed again")
                             .Register(r);
  m->rejected_ = &prometheus::BuildCounter()
                      .Name("rbdgrad_rejected_requests_total")
                      .Help("Calls refused before they were looked at, by reason: unauthenticated, client_rate, "
                            "client_concurrency, max_concurrent_requests")
                      .Register(r);
  m->queue_ = &prometheus::BuildHistogram()
                   .Name("rbdgrad_queue_seconds")
                   .Help("From acceptance to the start of the computation")
                   .Register(r);
  m->compute_ = &prometheus::BuildHistogram()
                     .Name("rbdgrad_compute_seconds")
                     .Help("In the backends")
                     .Register(r);
  m->total_ = &prometheus::BuildHistogram()
                   .Name("rbdgrad_total_seconds")
                   .Help("From acceptance to the response")
                   .Register(r);
  m->batch_states_ = &prometheus::BuildHistogram()
                          .Name("rbdgrad_batch_states")
                          .Help("States per backend call, after dynamic batching")
                          .Register(r);
  m->live_ = std::make_shared<LiveState>(std::move(queues), std::move(in_flight));
  if (!listen.empty()) {
    try {
      m->exposer_ = std::make_unique<prometheus::Exposer>(listen, 1);
    } catch (const std::exception& e) {
      return unavailable("metrics: cannot serve on " + listen + ": " + e.what());
    }
    m->exposer_->RegisterCollectable(m->registry_);
    m->exposer_->RegisterCollectable(m->live_);
    const std::vector<int> ports = m->exposer_->GetListeningPorts();
    m->port_ = ports.empty() ? 0 : ports.front();
  }
  out = std::move(m);
  return Status::ok();
}

Metrics::~Metrics() = default;

void Metrics::record(const RequestRecord& r) {
  const std::string backend = label(r.backend), mode = label(r.mode);
  requests_->Add({{"backend", backend},
                  {"mode", mode},
                  {"model", label(r.model)},
                  {"precision", label(r.precision)},
                  {"code", status_code_name(r.code)}})
      .Increment();
  const prometheus::Labels by_backend{{"backend", backend}, {"mode", mode}};
  if (r.parts.empty()) {
    if (r.code == StatusCode::kOk) states_->Add(by_backend).Increment(static_cast<double>(r.states));
    if (r.batch_states > 0) batch_states_->Add(by_backend, size_buckets()).Observe(static_cast<double>(r.batch_states));
  } else {
    split_requests_->Increment();
    for (const RequestRecord::Part& p : r.parts) {
      const prometheus::Labels part_labels{{"backend", label(p.backend)}, {"mode", label(p.mode)}};
      if (r.code == StatusCode::kOk) states_->Add(part_labels).Increment(static_cast<double>(p.states));
      batch_states_->Add(part_labels, size_buckets()).Observe(static_cast<double>(p.states));
    }
  }
  for (const std::string& failed : r.failed_backends) failovers_->Add({{"from_backend", failed}}).Increment();
  if (r.fallback_states > 0) fallback_states_->Add(by_backend).Increment(static_cast<double>(r.fallback_states));
  if (r.queue_seconds >= 0) queue_->Add(by_backend, time_buckets()).Observe(r.queue_seconds);
  if (r.compute_seconds >= 0) compute_->Add(by_backend, time_buckets()).Observe(r.compute_seconds);
  total_->Add(by_backend, time_buckets()).Observe(r.total_seconds);
}

void Metrics::record_rejection(std::string_view reason) {
  rejected_->Add({{"reason", std::string(reason)}}).Increment();
}

void Metrics::record_timeout(std::string_view backend) {
  timeouts_->Add({{"backend", std::string(backend)}}).Increment();
}

std::string Metrics::text() const {
  std::vector<prometheus::MetricFamily> families = registry_->Collect();
  for (prometheus::MetricFamily& f : live_->Collect()) families.push_back(std::move(f));
  return prometheus::TextSerializer().Serialize(families);
}

}  // namespace rbdgrad::server
