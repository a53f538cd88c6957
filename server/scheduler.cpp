#include "scheduler.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <limits>
#include <mutex>
#include <utility>

namespace rbdgrad::server {

namespace {

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// the precision a backend runs a request in: the asked one if it has it, else (auto) its best
std::uint32_t precision_on(const BackendState& b, std::uint32_t asked) {
  if (asked != 0) return (b.info.precisions & asked) ? asked : 0;
  for (std::uint32_t p : kPrecisionOrder)
    if (b.info.precisions & p) return p;
  return 0;
}

}  // namespace

Scheduler::Scheduler(const BackendPool& backends, const ModelRegistry& models, SchedulerConfig config)
    : backends_(backends),
      models_(models),
      config_(std::move(config)),
      suspect_(new std::atomic<bool>[backends.backends().size()]) {
  for (std::size_t i = 0; i < backends.backends().size(); ++i) suspect_[i].store(false);
}

double Scheduler::backend_timeout_us(double predicted_us) const noexcept {
  if (config_.backend_timeout_ms == 0) return 0;
  if (config_.backend_timeout_ms > 0) return static_cast<double>(config_.backend_timeout_ms) * 1e3;
  return std::max(1e6, 20 * predicted_us);
}

std::atomic<bool>* Scheduler::suspect_flag(const BackendState& backend) const noexcept {
  const auto& all = backends_.backends();
  if (all.empty() || &backend < all.data() || &backend >= all.data() + all.size()) return nullptr;
  return &suspect_[static_cast<std::size_t>(&backend - all.data())];
}

bool Scheduler::mark_suspect(const BackendState& backend) const noexcept {
  std::atomic<bool>* flag = suspect_flag(backend);
  return flag != nullptr && !flag->exchange(true);
}

bool Scheduler::mark_healthy(const BackendState& backend) const noexcept {
  std::atomic<bool>* flag = suspect_flag(backend);
  // a plain load first: the request path pays no write while nothing is suspect
  return flag != nullptr && flag->load(std::memory_order_relaxed) && flag->exchange(false);
}

bool Scheduler::suspect(const BackendState& backend) const noexcept {
  const std::atomic<bool>* flag = suspect_flag(backend);
  return flag != nullptr && flag->load(std::memory_order_relaxed);
}

bool Scheduler::calibrate_entry(const BackendState& backend, const ServedModel& model, std::uint32_t precision,
                                const CalibrationTable& file, bool remeasure,
                                const std::function<void(const std::string&)>& log, CalibrationEntry& entry,
                                bool& measured) const {
  InstancePool* pool = backends_.pool(backend.name, model);
  if (pool == nullptr) return false;
  CalibrationOptions options;
  options.sizes.assign(config_.calibration_sizes.begin(), config_.calibration_sizes.end());
  const std::string fingerprint = backend_fingerprint(backend) + "-" + model_fingerprint(model);
  const std::string what = backend.name + " " + model.name + " " + precision_label(precision);
  entry = CalibrationEntry{backend.name, model.name, precision, fingerprint, "", {}};
  // the plugin's own model first: it describes hardware that timing here may not reach
  const Status estimated = estimated_latency(pool->instance(0), precision, options, entry.latency);
  if (estimated) {
    entry.source = "the plugin's own model (estimate_latency)";
  } else if (estimated.code() != StatusCode::kUnimplemented) {
    log("calibration: " + what + ": " + estimated.message());
    return false;
  } else if (const CalibrationEntry* saved = file.find(backend.name, model.name, precision);
             !remeasure && saved != nullptr && saved->fingerprint == fingerprint && !saved->latency.empty()) {
    entry = *saved;
  } else if (config_.calibrate == "off" && !remeasure) {
    return false;  // off at start-up; an explicit Calibrate still measures
  } else {
    // the plugin's own batch limit
    if (backend.info.max_batch != 0)
      options.sizes.erase(std::remove_if(options.sizes.begin(), options.sizes.end(),
                                         [&](std::uint64_t n) { return n > backend.info.max_batch; }),
                          options.sizes.end());
    // a pool is the backend's queue: measuring through it keeps the instance exclusive
    const Status s = measure_latency(*pool, model, precision, options, entry.latency);
    if (!s) {
      log("calibration: " + what + ": not measured: " + s.message());
      return false;
    }
    entry.source = "measured " + utc_now();
    measured = true;
  }
  log("calibration: " + what + ": " + entry.latency.summary() + " (" + entry.source + ")");
  return true;
}

CalibrationTable Scheduler::calibration_file(const std::function<void(const std::string&)>& log) const {
  CalibrationTable file;
  if (!config_.calibration_file.empty()) {
    const Status s = CalibrationTable::load(config_.calibration_file, file);
    if (!s && s.code() != StatusCode::kNotFound) log("calibration: " + s.message() + "; measuring anew");
  }
  return file;
}

void Scheduler::save_calibration(const CalibrationTable& file, const CalibrationTable& measured,
                                 const std::function<void(const std::string&)>& log) const {
  if (config_.calibration_file.empty()) return;
  // keep what the file holds for backends and models not served this time
  CalibrationTable merged = file;
  for (const CalibrationEntry& e : measured.entries()) merged.set(e);
  if (Status s = merged.save(config_.calibration_file); !s) log("calibration: " + s.message());
}

void Scheduler::calibrate(bool remeasure, const std::function<void(const std::string&)>& log) {
  std::lock_guard calibrating(calibrating_);
  const CalibrationTable file = calibration_file(log);
  CalibrationTable table;
  bool measured = false;
  const auto models = models_.models();  // a scene registered meanwhile keeps its own entries (below)
  for (const BackendState& backend : backends_.backends()) {
    if (!backend.ready) continue;
    for (const auto& model : models) {
      for (std::uint32_t precision : kPrecisionOrder) {
        if ((backend.info.precisions & precision) == 0) continue;
        CalibrationEntry entry;
        if (calibrate_entry(backend, *model, precision, file, remeasure, log, entry, measured))
          table.set(std::move(entry));
      }
    }
  }
  if (measured) save_calibration(file, table, log);
  std::unique_lock lock(mutex_);
  // the entries of a scene registered after `models` was taken, which this run did not visit
  for (const CalibrationEntry& e : table_.entries()) {
    const bool visited = std::any_of(models.begin(), models.end(), [&](const auto& m) { return m->name == e.model; });
    if (!visited) table.set(e);
  }
  table_ = std::move(table);
}

void Scheduler::calibrate_model(const ServedModel& model, const std::function<void(const std::string&)>& log) {
  std::lock_guard calibrating(calibrating_);
  const CalibrationTable file = calibration_file(log);
  CalibrationTable table;
  bool measured = false;
  for (const BackendState& backend : backends_.backends()) {
    if (!backend.ready) continue;
    for (std::uint32_t precision : kPrecisionOrder) {
      if ((backend.info.precisions & precision) == 0) continue;
      CalibrationEntry entry;
      if (calibrate_entry(backend, model, precision, file, false, log, entry, measured)) table.set(std::move(entry));
    }
  }
  if (measured) save_calibration(file, table, log);
  std::unique_lock lock(mutex_);
  for (const CalibrationEntry& e : table.entries()) table_.set(e);
}

std::vector<Scheduler::Candidate> Scheduler::candidates(const ServedModel& model, const RouteQuery& query) const {
  std::vector<Candidate> out;
  for (const BackendState& backend : backends_.backends()) {
    if (!backend.ready) continue;
    const InstancePool* pool = backends_.pool(backend.name, model);
    if (pool == nullptr) continue;
    const std::uint32_t precision = precision_on(backend, query.precision);
    if (precision == 0) continue;
    if (query.exclude != nullptr &&
        std::find(query.exclude->begin(), query.exclude->end(), backend.name) != query.exclude->end())
      continue;
    const Plugin* plugin = backends_.plugin(backend.name);
    if (plugin == nullptr ||
        !plugin->can_run(model.desc.desc(), static_cast<rbdgrad_precision>(precision), query.outputs, query.n))
      continue;
    out.push_back({&backend, precision, pool, table_.find(backend.name, model.name, precision)});
  }
  // a suspect backend (a call on it timed out) only when no other can take the request
  const auto is_suspect = [&](const Candidate& x) { return suspect(*x.state); };
  if (std::any_of(out.begin(), out.end(), is_suspect) && !std::all_of(out.begin(), out.end(), is_suspect))
    out.erase(std::remove_if(out.begin(), out.end(), is_suspect), out.end());
  return out;
}

std::string Scheduler::choose_by_threshold(const ServedModel& model, const std::vector<Candidate>& c,
                                           std::uint64_t n) const {
  const auto [small_n, large_n] = thresholds_locked(model);
  const char* want = "cpu";
  if (small_n >= 0 && n <= static_cast<std::uint64_t>(small_n)) want = "fpga";
  else if (large_n >= 0 && n >= static_cast<std::uint64_t>(large_n)) want = "cuda";
  // a kind: among several backends of it (two GPUs), the cost policy picks
  for (const Candidate& x : c)
    if (x.state->kind == want) return want;
  return "";
}

std::string Scheduler::choose_by_cost(const std::vector<Candidate>& c, std::string_view kind, std::uint64_t n) const {
  std::string chosen;
  double best = std::numeric_limits<double>::infinity();
  for (const Candidate& x : c) {
    if (!kind.empty() && x.state->kind != kind) continue;
    if (x.entry == nullptr || x.entry->latency.empty()) continue;
    const double t = x.pool->predicted_wait_us() + x.entry->latency.predict_us(n);
    if (t < best) {
      best = t;
      chosen = x.state->name;
    }
  }
  return chosen;
}

Status Scheduler::route(const ServedModel& model, const RouteQuery& query, Route& out, double& predicted_us,
                        double* predicted_wait_us) const {
  predicted_us = 0;
  if (predicted_wait_us != nullptr) *predicted_wait_us = 0;
  std::string chosen(query.backend);
  std::shared_lock lock(mutex_);
  if (!chosen.empty()) {
    // a hint names a kind ("cuda"), or a backend ("cuda1"): among several of the kind, the one
    // predicted to finish first (else the first that serves the model: BackendPool's rule)
    if (backends_.resolve(chosen).size() > 1) {
      RouteQuery any = query;
      any.backend = {};
      const std::vector<Candidate> c = candidates(model, any);
      if (std::string best = choose_by_cost(c, chosen, query.n); !best.empty()) {
        chosen = std::move(best);
      } else {
        // no latency model: the least busy of the kind (the first on a tie)
        std::size_t least = std::numeric_limits<std::size_t>::max();
        std::string pick;
        for (const Candidate& x : c) {
          if (x.state->kind != chosen) continue;
          const PoolLoad load = x.pool->load();
          if (load.queued + load.running < least) {
            least = load.queued + load.running;
            pick = x.state->name;
          }
        }
        if (!pick.empty()) chosen = std::move(pick);
      }
    }
  } else {
    const std::vector<Candidate> c = candidates(model, query);
    if (c.empty() && query.exclude != nullptr && !query.exclude->empty())
      return unavailable("no other backend can take the request");
    std::string kind;
    if (config_.policy == "threshold") kind = choose_by_threshold(model, c, query.n);
    // cost: the earliest predicted completion among the backends (of that kind) with a model
    chosen = choose_by_cost(c, kind, query.n);
    if (chosen.empty() && !kind.empty()) {
      for (const Candidate& x : c) {
        if (x.state->kind == kind) {
          chosen = x.state->name;
          break;
        }
      }
    }
    // no model at all: BackendPool's own rule (the cpu, else the first that serves the model),
    // unless that is a backend that failed already
    if (chosen.empty() && query.exclude != nullptr && !query.exclude->empty()) chosen = c.front().state->name;
    // nor one that is suspect while another can take the request
    if (chosen.empty() && !c.empty()) {
      Route usual;
      if (backends_.route(model, "", query.precision, usual) && suspect(*usual.backend) &&
          std::none_of(c.begin(), c.end(), [&](const Candidate& x) { return x.state == usual.backend; }))
        chosen = c.front().state->name;
    }
  }
  if (Status s = backends_.route(model, chosen, query.precision, out); !s) return s;
  if (const CalibrationEntry* e = table_.find(out.backend->name, model.name, out.precision))
    predicted_us = e->latency.predict_us(query.n);
  if (predicted_wait_us != nullptr) *predicted_wait_us = out.pool->predicted_wait_us();
  return Status::ok();
}

std::vector<SplitPart> Scheduler::split(const ServedModel& model, const RouteQuery& query, std::uint32_t precision,
                                        double alone_us) const {
  std::vector<SplitPart> parts;
  if (config_.policy != "cost" || config_.split_min_states <= 0 || !query.backend.empty() ||
      query.n < static_cast<std::uint64_t>(config_.split_min_states) || !(alone_us > 0))
    return parts;
  RouteQuery q = query;
  q.precision = precision;
  std::shared_lock lock(mutex_);
  struct Option {
    const Candidate* candidate;
    double wait_us;
  };
  const std::vector<Candidate> c = candidates(model, q);
  std::vector<Option> options;
  for (const Candidate& x : c)
    if (x.entry != nullptr && !x.entry->latency.empty()) options.push_back({&x, x.pool->predicted_wait_us()});
  if (options.size() < 2) return parts;

  // the states option i finishes by time t: its model grows with N (nearly: a measured point may
  // dip), so a binary search
  const auto states_by = [&](const Option& o, double t) -> std::uint64_t {
    const LatencyModel& m = o.candidate->entry->latency;
    if (o.wait_us + m.predict_us(1) > t) return 0;
    std::uint64_t lo = 1, hi = query.n;
    while (lo < hi) {
      const std::uint64_t mid = lo + (hi - lo + 1) / 2;
      if (o.wait_us + m.predict_us(mid) <= t) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  };
  const auto total_by = [&](double t) {
    std::uint64_t total = 0;
    for (const Option& o : options) total += states_by(o, t);
    return total;
  };
  // the earliest time by which the options together finish every state; alone_us suffices
  double lo = 0, hi = alone_us;
  if (total_by(hi) < query.n) return parts;
  for (int i = 0; i < 60 && hi - lo > 1e-3 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (total_by(mid) >= query.n ? hi : lo) = mid;
  }
  std::vector<std::uint64_t> share(options.size());
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < options.size(); ++i) total += share[i] = states_by(options[i], hi);
  // more than n by then: the last shares give the excess back (fewer states never take longer)
  for (std::size_t i = options.size(); i-- > 0 && total > query.n;) {
    const std::uint64_t give = std::min(share[i], total - query.n);
    share[i] -= give;
    total -= give;
  }
  double makespan = 0;
  std::size_t used = 0;
  for (std::size_t i = 0; i < options.size(); ++i) {
    if (share[i] == 0) continue;
    ++used;
    makespan = std::max(makespan, options[i].wait_us + options[i].candidate->entry->latency.predict_us(share[i]));
  }
  if (used < 2 || makespan > 0.9 * alone_us) return parts;
  std::uint64_t first = 0;
  for (std::size_t i = 0; i < options.size(); ++i) {
    if (share[i] == 0) continue;
    SplitPart p;
    if (!backends_.route(model, options[i].candidate->state->name, precision, p.route)) return {};
    p.first = first;
    p.n = share[i];
    p.wait_us = options[i].wait_us;
    p.compute_us = options[i].candidate->entry->latency.predict_us(share[i]);
    first += share[i];
    parts.push_back(p);
  }
  return parts;
}

std::vector<Prediction> Scheduler::predictions(const ServedModel& model, const RouteQuery& query) const {
  std::shared_lock lock(mutex_);
  std::vector<Prediction> out;
  for (const Candidate& x : candidates(model, query)) {
    Prediction p{x.state->name, x.precision, x.pool->predicted_wait_us(), 0, false};
    if (x.entry != nullptr && !x.entry->latency.empty()) {
      p.compute_us = x.entry->latency.predict_us(query.n);
      p.has_model = true;
    }
    out.push_back(std::move(p));
  }
  return out;
}

CalibrationTable Scheduler::table() const {
  std::shared_lock lock(mutex_);
  return table_;
}

std::vector<std::pair<std::uint64_t, std::string>> Scheduler::crossovers(const ServedModel& model,
                                                                          std::uint32_t precision,
                                                                          std::uint64_t max_n) const {
  std::shared_lock lock(mutex_);
  return crossovers_locked(model, precision, max_n);
}

std::vector<std::pair<std::uint64_t, std::string>> Scheduler::crossovers_locked(const ServedModel& model,
                                                                                 std::uint32_t precision,
                                                                                 std::uint64_t max_n) const {
  std::vector<const LatencyModel*> models;
  std::vector<std::string> names;
  for (const BackendState& backend : backends_.backends()) {
    if (!backend.ready || backends_.pool(backend.name, model) == nullptr) continue;
    const std::uint32_t p = precision_on(backend, precision);
    const CalibrationEntry* e = p == 0 ? nullptr : table_.find(backend.name, model.name, p);
    if (e == nullptr) continue;
    models.push_back(&e->latency);
    names.push_back(backend.name);
  }
  std::vector<std::pair<std::uint64_t, std::string>> out;
  for (const Crossover& c : server::crossovers(models, max_n)) out.emplace_back(c.n, names[c.fastest]);
  return out;
}

std::pair<std::int64_t, std::int64_t> Scheduler::thresholds(const ServedModel& model) const {
  std::shared_lock lock(mutex_);
  return thresholds_locked(model);
}

std::pair<std::int64_t, std::int64_t> Scheduler::thresholds_locked(const ServedModel& model) const {
  std::int64_t small_n = config_.small_n, large_n = config_.large_n;
  if (small_n >= 0 && large_n >= 0) return {small_n, large_n};
  const auto c = crossovers_locked(model, 0, std::uint64_t{1} << 20);
  std::int64_t derived_small = -1, derived_large = -1;
  // by kind: cuda0 and cuda1 are both "cuda"
  const auto kind_of = [&](const std::string& name) -> std::string {
    for (const BackendState& b : backends_.backends())
      if (b.name == name) return b.kind;
    return name;
  };
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::string kind = kind_of(c[i].second);
    if (kind == "fpga" && derived_small < 0) {
      // the fpga is fastest until the next kind takes over
      std::size_t j = i + 1;
      while (j < c.size() && kind_of(c[j].second) == "fpga") ++j;
      derived_small = j < c.size() ? static_cast<std::int64_t>(c[j].first) - 1 : std::int64_t{1} << 20;
    }
    if (kind == "cuda" && derived_large < 0) derived_large = static_cast<std::int64_t>(c[i].first);
  }
  return {small_n >= 0 ? small_n : derived_small, large_n >= 0 ? large_n : derived_large};
}

}  // namespace rbdgrad::server
