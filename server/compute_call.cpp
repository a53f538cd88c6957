// A compute request's preparation (gRPC thread) and execution (pool thread or inline).
#include "compute_call.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <string_view>

#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>
#include <spdlog/spdlog.h>

#include "coalescer.hpp"
#include "common/batch_view.hpp"
#include "metrics.hpp"
#include "proto_enums.hpp"

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

std::uint64_t micros(ComputeCall::Clock::duration d) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(d).count();
  return us > 0 ? static_cast<std::uint64_t>(us) : 0;
}

Status with_prefix(const std::string& prefix, const Status& s) { return {s.code(), prefix + s.message()}; }

// The request's outputs as rbdgrad_output flags (Output k is flag 1 << (k - 1)); unknown values
// are left out here and refused by RequestBatch.
std::uint32_t output_flags(const v1::ComputeRequest& request) {
  static_assert(RBDGRAD_OUTPUT_QDD == 1u << (v1::OUTPUT_QDD - 1) && RBDGRAD_OUTPUT_DQDD_DQ == 1u << (v1::OUTPUT_DQDD_DQ - 1) &&
                    RBDGRAD_OUTPUT_M == 1u << (v1::OUTPUT_M - 1),
                "Output k of the proto is output flag 1 << (k - 1) of the plugin ABI");
  std::uint32_t flags = 0;
  for (int o : request.outputs())
    if (o >= 1 && o <= 8) flags |= 1u << (o - 1);
  return flags;
}

double millis(ComputeCall::Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

}  // namespace

std::unique_ptr<Watchdog> ComputeContext::make_watchdog(const Scheduler& scheduler) {
  if (scheduler.config().backend_timeout_ms == 0) return nullptr;
  return std::make_unique<Watchdog>([](const std::shared_ptr<CallAttempt>& a) { ComputeCall::expired(a); });
}

ComputeContext::Admission ComputeContext::admit() noexcept {
  if (stopping_.load(std::memory_order_relaxed)) return Admission::kShuttingDown;
  if (in_flight_.fetch_add(1, std::memory_order_relaxed) >= limits_.max_concurrent_requests) {
    in_flight_.fetch_sub(1, std::memory_order_relaxed);
    return Admission::kTooManyInFlight;
  }
  return Admission::kAdmitted;
}

Status ComputeCall::prepare(const grpc::ByteBuffer& message, const ComputeContext& context,
                            std::int64_t stream_index, Clock::time_point deadline) {
  deadline_ = deadline;
  context_ = &context;
  const std::string stream_prefix = stream_index >= 0 ? "stream message " + std::to_string(stream_index) + ": " : "";

  // parse: a message that is no ComputeRequest is the client's error, not an INTERNAL one
  if (message.Valid()) {
    grpc::ByteBuffer view(message);  // shares the slices, no copy
    grpc::ProtoBufferReader reader(&view);
    if (!reader.status().ok() || !request_.ParseFromZeroCopyStream(&reader)) {
      return invalid_argument(stream_prefix + "malformed ComputeRequest (" + std::to_string(message.Length()) +
                              " bytes): not a valid protobuf encoding of rbdgrad.v1.ComputeRequest");
    }
  }
  // a request with an id is named by it, in messages as in RequestBatch's
  prefix_ = request_.request_id().empty() ? stream_prefix : "request '" + request_.request_id() + "': ";

  // a scene: its model, and the request made into one of that model (apply_scene)
  const ServedModel* model = nullptr;
  if (!request_.scene().empty()) {
    model = context.models().find_scene(request_.scene());
    if (model == nullptr) {
      const std::string scenes = context.models().scene_names();
      return not_found(prefix_ + "scene '" + request_.scene() + "' is not configured (scenes: " +
                       (scenes.empty() ? std::string("none") : scenes) + ")");
    }
    if (Status s = apply_scene(*model->scene, model->name, model->model.nv, request_); !s)
      return with_prefix(prefix_, s);
  } else {
    model = context.models().find(request_.model());
    if (model == nullptr) {
      return not_found(prefix_ + "model '" + request_.model() + "' is not loaded (loaded models: " +
                       context.models().names() + ")");
    }
  }
  std::string_view backend;
  if (!backend_name(request_.backend(), backend)) {
    return invalid_argument(prefix_ + "backend has unknown value " + std::to_string(request_.backend()));
  }
  std::uint32_t precision = 0;
  if (!precision_flag(request_.precision(), precision)) {
    return invalid_argument(prefix_ + "precision has unknown value " + std::to_string(request_.precision()));
  }
  hint_ = std::string(backend);
  RouteQuery query;
  query.backend = backend;
  query.precision = precision;
  query.n = request_.num_states();
  query.outputs = output_flags(request_);
  double wait_us = 0;
  if (Status s = context.scheduler().route(*model, query, route_, predicted_us_, &wait_us); !s)
    return with_prefix(prefix_, s);
  if (hint_.empty() && predicted_us_ > 0) {
    std::vector<SplitPart> shares = context.scheduler().split(*model, query, route_.precision, wait_us + predicted_us_);
    if (!shares.empty()) {
      // the response names the backend with the most states; the deadline sees the slowest share
      const auto most = std::max_element(shares.begin(), shares.end(),
                                         [](const SplitPart& a, const SplitPart& b) { return a.n < b.n; });
      const auto last = std::max_element(shares.begin(), shares.end(), [](const SplitPart& a, const SplitPart& b) {
        return a.wait_us + a.compute_us < b.wait_us + b.compute_us;
      });
      route_ = most->route;
      wait_us = last->wait_us;
      predicted_us_ = last->compute_us;
      parts_.resize(shares.size());
      for (std::size_t i = 0; i < shares.size(); ++i) {
        parts_[i].call = this;
        parts_[i].part = shares[i];
      }
    }
  }
  // a request that would miss its deadline fails now instead of taking a backend's time
  if (deadline_ != Clock::time_point::max() && predicted_us_ > 0) {
    const double left_us = std::chrono::duration<double, std::micro>(deadline_ - Clock::now()).count();
    if (wait_us + predicted_us_ > left_us) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "cannot finish before its deadline: %.0f us left, backend %s predicts %.0f us (%.0f us waiting "
                    "for an instance + %.0f us computing)",
                    std::max(0.0, left_us), route_.backend->name.c_str(), wait_us + predicted_us_, wait_us,
                    predicted_us_);
      return deadline_exceeded(prefix_ + text);
    }
  }
  context_ = &context;
  model_ = model;

  const auto max_states = static_cast<std::uint32_t>(
      std::min<std::int64_t>(context.limits().max_states_per_request, std::numeric_limits<std::uint32_t>::max()));
  if (Status s = RequestBatch::from_request(request_, model->model.nv, route_.precision, max_states, batch_,
                                             &response_);
      !s) {
    // RequestBatch names a request with an id itself
    return request_.request_id().empty() ? with_prefix(prefix_, s) : s;
  }
  // the backend's own word on this (precision, outputs, N): e.g. a batch above its max_batch
  const rbdgrad_batch& b = batch_.batch();
  if (Status s = route_.plugin->can_run(model->desc.desc(), route_.precision, b.outputs, b.n); !s) {
    return with_prefix(prefix_, s);
  }
  for (PartJob& p : parts_) {
    const Route& r = p.part.route;
    if (Status s = r.plugin->can_run(model->desc.desc(), r.precision, b.outputs, p.part.n); !s)
      return with_prefix(prefix_, s);
    p.batch = plugin::states_of(b, batch_.nv(), p.part.first, p.part.n);
  }
  return Status::ok();
}

template <class Step>
void ComputeCall::conclude(Step&& step) noexcept {
  try {
    if (!step()) return;  // it goes on elsewhere, which concludes it
  } catch (const std::exception& e) {
    status_ = Status(StatusCode::kInternal, prefix_ + "unexpected error: " + e.what());
  } catch (...) {
    status_ = Status(StatusCode::kInternal, prefix_ + "unexpected error");
  }
  record();
  complete();
}

void ComputeCall::run(PluginInstance& instance) noexcept {
  conclude([&] {
    const bool answered = run_stage(instance, true);
    // free before the answer goes out: the client's next request must not find it busy
    if (answered) release_instance();
    return answered;
  });
}

void ComputeCall::submit() {
  if (!parts_.empty()) {
    parts_left_.store(parts_.size(), std::memory_order_relaxed);
    batch_states_ = batch_.num_states();
    // The last share to finish may complete (and free) the call: nothing here is touched after
    // the last submit. Every share but the last is queued as too large to run inline, so that
    // they all start on pool threads before the last may run on this one.
    PartJob* const jobs = parts_.data();
    const std::size_t count = parts_.size();
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint64_t states = i + 1 < count ? std::numeric_limits<std::uint64_t>::max() : jobs[i].part.n;
      jobs[i].part.route.pool->submit(jobs[i], states, jobs[i].part.compute_us);
    }
    return;
  }
  Coalescer* coalescer = context_->coalescer();
  if (coalescer != nullptr && coalescer->takes(*this)) {
    coalescer->add(*this);
    return;
  }
  batch_states_ = batch_.num_states();
  route_.pool->submit(*this, inline_states(), predicted_us_);
}

void ComputeCall::PartJob::run(PluginInstance& instance) noexcept {
  started = Clock::now();
  if (started > call->deadline_) {
    status = Status(StatusCode::kDeadlineExceeded, "");
  } else {
    try {
      status = instance.compute(batch);
    } catch (const std::exception& e) {
      status = Status(StatusCode::kInternal, std::string("unexpected error: ") + e.what());
    } catch (...) {
      status = Status(StatusCode::kInternal, "unexpected error");
    }
    compute = Clock::now() - started;
  }
  release_instance();  // this share is done with it, before the call may answer
  call->part_done();   // may complete and free the call, and this job with it
}

void ComputeCall::part_done() noexcept {
  if (parts_left_.fetch_sub(1, std::memory_order_acq_rel) != 1) return;
  conclude([&] {
    // queue_us until the first share started; compute_us the longest share
    started_ = parts_.front().started;
    const PartJob* failed = nullptr;
    for (const PartJob& p : parts_) {
      started_ = std::min(started_, p.started);
      compute_time_ = std::max(compute_time_, p.compute);
      if (!p.status && failed == nullptr) failed = &p;
    }
    if (failed != nullptr) return !rerun_unsplit(*failed);  // rerun: the usual path concludes it
    finish();
    return true;
  });
}

bool ComputeCall::rerun_unsplit(const PartJob& failed) {
  if (failed.status.code() == StatusCode::kDeadlineExceeded) {
    status_ = deadline_exceeded(prefix_ + "its deadline passed after " + std::to_string(micros(failed.started - accepted_)) +
                                " us in the queue, before it was computed");
    return false;
  }
  unsplit_ = true;
  route_ = failed.part.route;
  Status failure = failed.status;
  if (failure.code() == StatusCode::kUnavailable || failure.code() == StatusCode::kInternal) {
    // the backend failed as a whole: the next best takes the whole request (failover)
    if (!prepare_failover(failure)) {
      status_ = with_prefix(prefix_, failure);
      return false;
    }
  }
  // else a state failed, numbered within its share: that backend again on every state says
  // which, and applies the fixed-point fallback where it should
  route_.pool->submit(*this, inline_states(), predicted_us_);
  return true;
}

void ComputeCall::finish_in_group(PluginInstance& instance, const rbdgrad_batch& group, std::uint64_t first,
                                  Clock::time_point started, Clock::duration compute, std::size_t group_requests,
                                  std::uint64_t group_states) noexcept {
  conclude([&] {
    // the group call marks every state failed when it failed as a whole (GroupJob::run)
    const rbdgrad_batch& own = batch_.batch();
    bool all_ok = group.state_status != nullptr;
    for (std::uint64_t k = 0; all_ok && k < own.n; ++k) all_ok = group.state_status[first + k] == RBDGRAD_OK;
    if (!all_ok) {
      // computed again alone: the usual path, with its own messages, failover and fallback
      batch_states_ = own.n;
      return run_stage(instance);
    }
    started_ = started;
    compute_time_ = compute;
    batch_requests_ = group_requests;
    batch_states_ = group_states;
    const auto nv = static_cast<std::size_t>(batch_.nv());
    for (int o = 0; o < 8; ++o) {
      const std::uint32_t flag = 1u << o;
      if ((own.outputs & flag) == 0) continue;
      const std::size_t per_state = ((flag & plugin::kMatrixOutputs) ? nv * nv : nv) * plugin::scalar_bytes(own.precision);
      std::memcpy(plugin::output_pointer(own, flag),
                  static_cast<const std::byte*>(plugin::output_pointer(group, flag)) + first * per_state,
                  own.n * per_state);
    }
    if (own.state_status != nullptr)
      std::memcpy(own.state_status, group.state_status + first, own.n * sizeof(std::int32_t));
    finish();
    return true;
  });
}

void ComputeCall::record() const {
  if (context_ == nullptr || context_->metrics() == nullptr) return;
  RequestRecord r;
  if (route_.backend != nullptr) {
    r.backend = route_.backend->name;
    r.mode = route_.backend->description.mode;
    r.precision = precision_label(route_.precision);
  }
  if (model_ != nullptr) r.model = model_->name;
  r.code = status_.code();
  r.states = request_.num_states();
  const Clock::time_point now = Clock::now();
  if (started_ != Clock::time_point{}) r.queue_seconds = std::chrono::duration<double>(started_ - accepted_).count();
  if (compute_time_ != Clock::duration{}) r.compute_seconds = std::chrono::duration<double>(compute_time_).count();
  r.total_seconds = std::chrono::duration<double>(now - accepted_).count();
  r.failed_backends = failed_;
  r.batch_states = batch_states_;
  if (split()) {
    for (const PartJob& p : parts_)
      r.parts.push_back({p.part.route.backend->name, p.part.route.backend->description.mode, p.part.n});
  }
  if (in_fallback_ && status_) r.fallback_states = fallback_states_.size();
  context_->metrics()->record(r);
}

void ComputeCall::record_refusal(const Status& refusal) const {
  if (context_ == nullptr || context_->metrics() == nullptr) return;
  RequestRecord r;
  const ServedModel* model = request_.scene().empty() ? context_->models().find(request_.model())
                                                     : context_->models().find_scene(request_.scene());
  if (model != nullptr) r.model = model->name;
  r.code = refusal.code();
  r.states = request_.num_states();
  r.total_seconds = std::chrono::duration<double>(Clock::now() - accepted_).count();
  context_->metrics()->record(r);
}

std::uint64_t ComputeCall::inline_states() const noexcept {
  // A call on the thread that received it cannot be answered before that thread is back (gRPC
  // sends a unary answer once its handler has returned): under a bound, device backends' calls go
  // to their pool's thread, where a hang can be left behind. The CPU backend runs in-process.
  if (context_->watchdog() != nullptr && route_.backend->kind != "cpu" &&
      context_->scheduler().backend_timeout_us(predicted_us_) > 0)
    return std::numeric_limits<std::uint64_t>::max();
  return batch_.num_states();
}

bool ComputeCall::compute_batch(PluginInstance& instance, bool watched, Status& computed) {
  Watchdog* const watchdog = watched ? context_->watchdog() : nullptr;
  const Scheduler& scheduler = context_->scheduler();
  const double limit_us = watchdog != nullptr ? scheduler.backend_timeout_us(predicted_us_) : 0;
  if (limit_us <= 0) {
    computed = instance.compute(batch_.batch());
  } else {
    auto attempt = std::make_shared<CallAttempt>();
    attempt->call = this;
    attempt->started = started_;
    attempt->deadline =
        started_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::micro>(limit_us));
    attempt->backend = route_.backend;
    attempt->scheduler = &scheduler;
    attempt->batch = batch_.batch();
    watchdog->add(attempt);
    computed = instance.compute(attempt->batch);
    bool late = false;
    {
      std::lock_guard lock(attempt->mutex);
      late = attempt->state == CallAttempt::State::kTimedOut;
      if (attempt->state == CallAttempt::State::kRunning) attempt->state = CallAttempt::State::kDone;
    }
    if (late) {
      late_result(*attempt, computed);  // the request is another thread's now
      return false;
    }
    watchdog->remove(*attempt);
  }
  compute_time_ += Clock::now() - started_;
  if (computed && scheduler.mark_healthy(*route_.backend))
    spdlog::info("backend {}: a call succeeded again: no longer suspect, routed to again", route_.backend->name);
  return true;
}

void ComputeCall::expired(const std::shared_ptr<CallAttempt>& attempt) noexcept {
  std::unique_lock lock(attempt->mutex);
  if (attempt->state != CallAttempt::State::kRunning) return;  // it returned meanwhile
  // alive: the call waits for its compute, which has not returned (and cannot settle without the lock)
  ComputeCall& call = *attempt->call;
  bool rerun = false;
  try {
    rerun = call.take_over(*attempt);
  } catch (const std::exception& e) {
    spdlog::error("{}cannot move the request off its timed-out backend: {}", call.prefix_, e.what());
  } catch (...) {
    spdlog::error("{}cannot move the request off its timed-out backend", call.prefix_);
  }
  attempt->state = rerun ? CallAttempt::State::kTimedOut : CallAttempt::State::kWaiting;
  lock.unlock();
  if (!rerun) return;
  // the call is this thread's now; on a pool thread of the next backend (never inline here)
  InstancePool* const pool = call.route_.pool;
  pool->submit(call, std::numeric_limits<std::uint64_t>::max(), call.predicted_us_);
}

bool ComputeCall::take_over(CallAttempt& attempt) {
  const BackendState& hung = *route_.backend;
  const Scheduler& scheduler = context_->scheduler();
  const double ran_ms = millis(Clock::now() - attempt.started);
  const double limit_ms = millis(attempt.deadline - attempt.started);
  char text[160];
  std::snprintf(text, sizeof text, "timed out: still running after %.0f ms (limit %.0f ms, predicted %.0f us)", ran_ms,
                limit_ms, predicted_us_);
  const std::string why = hung.name + ": " + text;
  if (Metrics* m = context_->metrics()) m->record_timeout(hung.name);
  if (scheduler.mark_suspect(hung))
    spdlog::warn("backend {}: a call {}: suspect, avoided by routing until a call on it succeeds", hung.name, text);

  // where it runs again: as a failover, without the backends that failed it (hung included)
  std::vector<std::string> exclude = failed_;
  exclude.push_back(hung.name);
  RouteQuery query;
  query.backend = hint_;
  std::uint32_t asked = 0;
  if (precision_flag(request_.precision(), asked)) query.precision = asked;
  query.n = request_.num_states();
  query.outputs = output_flags(request_);
  query.exclude = &exclude;
  Route next;
  double predicted = 0;
  const Status routed = context_->scheduler().route(*model_, query, next, predicted);
  if (!routed || std::find(exclude.begin(), exclude.end(), next.backend->name) != exclude.end()) {
    spdlog::warn("{}backend {} {}; no other backend can take the request{}{}: it waits for the call", prefix_,
                 hung.name, text, routed ? "" : ": ", routed ? "" : routed.message());
    return false;
  }
  if (Status s = next.plugin->can_run(model_->desc.desc(), next.precision, batch_.batch().outputs, query.n); !s) {
    spdlog::warn("{}backend {} {}; {} cannot take the request ({}): it waits for the call", prefix_, hung.name, text,
                 next.backend->name, s.message());
    return false;
  }
  // the inputs again, in the next backend's precision, into buffers of their own
  RequestBatch batch;
  v1::ComputeResponse fresh;
  const auto max_states = static_cast<std::uint32_t>(std::min<std::int64_t>(
      context_->limits().max_states_per_request, std::numeric_limits<std::uint32_t>::max()));
  if (Status s = RequestBatch::from_request(request_, model_->model.nv, next.precision, max_states, batch, &fresh);
      !s) {
    spdlog::warn("{}backend {} {}; cannot prepare it for {} ({}): it waits for the call", prefix_, hung.name, text,
                 next.backend->name, s.message());
    return false;
  }
  spdlog::warn("{}backend {} {}: the request runs again on {}", prefix_, hung.name, text, next.backend->name);
  // the hung call may still write into its buffers and its response's tensors: the attempt keeps
  // them (moves and swaps hand over heap blocks, which stay where they are) until it returns
  attempt.buffers = std::move(batch_);
  attempt.response.Swap(&response_);
  response_.Swap(&fresh);
  batch_ = std::move(batch);
  failed_.push_back(hung.name);
  failovers_.push_back(why);
  route_ = next;
  predicted_us_ = predicted;
  return true;
}

void ComputeCall::late_result(CallAttempt& attempt, const Status& computed) noexcept {
  const double ran_ms = millis(Clock::now() - attempt.started);
  const std::string& name = attempt.backend->name;
  if (computed) {
    spdlog::info("backend {}: the call that timed out returned after {:.0f} ms; its result is dropped (the request "
                 "was answered elsewhere)",
                 name, ran_ms);
    if (attempt.scheduler->mark_healthy(*attempt.backend))
      spdlog::info("backend {}: a call succeeded again: no longer suspect, routed to again", name);
  } else {
    spdlog::warn("backend {}: the call that timed out failed after {:.0f} ms: {}", name, ran_ms, computed.message());
  }
}

bool ComputeCall::run_stage(PluginInstance& instance, bool watched) {
  if (in_fallback_) {
    const Clock::time_point started = Clock::now();
    const Status computed = instance.compute(fallback_batch_.batch());
    compute_time_ += Clock::now() - started;
    if (!computed) {
      // the backend numbers the fallback's states from 0: say which of the request's they are
      std::string states;
      for (std::uint32_t k : fallback_states_) states += (states.empty() ? "" : ", ") + std::to_string(k);
      status_ = with_prefix(prefix_, Status(computed.code(), "the floating-point fallback of states " + states +
                                                                 " (the fixed-point range could not hold them; "
                                                                 "numbered from 0 in this order) failed: " +
                                                                 computed.message()));
    } else {
      finish();
    }
    return true;
  }
  started_ = Clock::now();
  if (started_ > deadline_) {
    status_ = deadline_exceeded(prefix_ + "its deadline passed after " + std::to_string(micros(started_ - accepted_)) +
                                " us in the queue, before it was computed");
    return true;
  }
  Status computed;
  if (!compute_batch(instance, watched, computed)) return false;  // timed out: it goes on elsewhere
  if (computed) {
    finish();
    return true;
  }
  if (prepare_failover(computed)) {
    // run() happens again on the next backend's pool (maybe right here); this run is over
    route_.pool->submit(*this, inline_states(), predicted_us_);
    return false;
  }
  bool fallback = false;
  if (Status s = prepare_fallback(computed, fallback); !s) {
    status_ = with_prefix(prefix_, s);
    return true;
  }
  if (!fallback) {
    // a per-state failure fails the request: the plugin's message names the state
    status_ = with_prefix(prefix_, computed);
    return true;
  }
  in_fallback_ = true;
  // run() happens again on the fallback's pool (maybe right here); this run is over
  fallback_route_.pool->submit(*this, fallback_states_.size());
  return false;
}

bool ComputeCall::prepare_failover(Status& failure) {
  // a whole-backend failure (a lost device, a bug), of a request the scheduler placed
  if (!hint_.empty() || (failure.code() != StatusCode::kUnavailable && failure.code() != StatusCode::kInternal))
    return false;
  failed_.push_back(route_.backend->name);
  failovers_.push_back(failure.message());  // the plugin loader's message names the backend
  RouteQuery query;
  query.precision = 0;
  std::uint32_t asked = 0;
  if (precision_flag(request_.precision(), asked)) query.precision = asked;
  query.n = request_.num_states();
  query.outputs = output_flags(request_);
  query.exclude = &failed_;
  Route next;
  double predicted = 0;
  if (Status s = context_->scheduler().route(*model_, query, next, predicted); !s) {
    failure = Status(failure.code(), failure.message() + "; no failover: " + s.message());
    return false;
  }
  // the inputs again, in the next backend's precision
  response_.Clear();
  RequestBatch batch;
  const auto max_states = static_cast<std::uint32_t>(std::min<std::int64_t>(
      context_->limits().max_states_per_request, std::numeric_limits<std::uint32_t>::max()));
  if (Status s = RequestBatch::from_request(request_, model_->model.nv, next.precision, max_states, batch, &response_);
      !s) {
    failure = Status(failure.code(), failure.message() + "; no failover: " + s.message());
    return false;
  }
  batch_ = std::move(batch);
  route_ = next;
  predicted_us_ = predicted;
  return true;
}

namespace {

// The states `states` of `in` (per_state scalars each), in that order, into `out`.
void slice_states(const v1::Tensor& in, const std::vector<std::uint32_t>& states, std::size_t per_state,
                  v1::Tensor& out) {
  if (in.data().empty()) return;
  const std::size_t bytes = per_state * (in.type() == v1::SCALAR_TYPE_F32 ? sizeof(float) : sizeof(double));
  out.set_type(in.type());
  std::string* data = out.mutable_data();
  data->reserve(bytes * states.size());
  for (std::uint32_t k : states) data->append(in.data(), k * bytes, bytes);
}

}  // namespace

Status ComputeCall::prepare_fallback(const Status& failure, bool& prepared) {
  prepared = false;
  const rbdgrad_batch& b = batch_.batch();
  const std::string& fallback = context_->fixed_point_fallback();
  if (b.precision != RBDGRAD_PRECISION_FIXED_Q16_16 || fallback.empty() || b.state_status == nullptr) {
    return Status::ok();
  }
  fallback_states_.clear();
  for (std::uint64_t k = 0; k < b.n; ++k) {
    if (b.state_status[k] == RBDGRAD_OK) continue;
    // another failure (a singular M, a device error) is not the format's doing: it stands
    if (b.state_status[k] != RBDGRAD_ERROR_OUT_OF_RANGE) return Status::ok();
    fallback_states_.push_back(static_cast<std::uint32_t>(k));
  }
  if (fallback_states_.empty()) return Status::ok();  // the whole batch failed: nothing to re-run

  // the fallback backend in its best floating-point precision
  if (Status s = context_->backends().route(*model_, fallback, 0, fallback_route_); !s) {
    return Status(failure.code(), failure.message() + "; no fixed-point fallback: " + s.message());
  }
  if (fallback_route_.precision == RBDGRAD_PRECISION_FIXED_Q16_16) {
    return Status(failure.code(), failure.message() + "; no fixed-point fallback: backend " + fallback +
                                      " computes in fixed point only");
  }
  // the request, cut down to those states
  const int nv = model_->model.nv;
  const auto n1 = static_cast<std::size_t>(nv);
  v1::ComputeRequest sub = request_;
  for (v1::Tensor* t : {sub.mutable_q(), sub.mutable_qd(), sub.mutable_u(), sub.mutable_minv(), sub.mutable_fext()}) t->Clear();
  sub.set_num_states(static_cast<std::uint32_t>(fallback_states_.size()));
  slice_states(request_.q(), fallback_states_, n1, *sub.mutable_q());
  slice_states(request_.qd(), fallback_states_, n1, *sub.mutable_qd());
  slice_states(request_.u(), fallback_states_, n1, *sub.mutable_u());
  slice_states(request_.minv(), fallback_states_, n1 * n1, *sub.mutable_minv());
  slice_states(request_.fext(), fallback_states_, 6 * n1, *sub.mutable_fext());
  if (Status s = RequestBatch::from_request(sub, nv, fallback_route_.precision, sub.num_states(), fallback_batch_);
      !s) {
    return Status(StatusCode::kInternal, "cannot prepare the fixed-point fallback: " + s.message());
  }
  const rbdgrad_batch& fb = fallback_batch_.batch();
  if (Status s = fallback_route_.plugin->can_run(model_->desc.desc(), fallback_route_.precision, fb.outputs, fb.n);
      !s) {
    return Status(failure.code(), failure.message() + "; no fixed-point fallback: " + s.message());
  }
  prepared = true;
  return Status::ok();
}

void ComputeCall::finish() {
  const v1::ScalarType type = request_.output_type();
  batch_.to_response(response_, type);
  // the enum says the kind; the name which backend of it (cuda0, cuda1)
  response_.set_backend(backend_enum(route_.backend->kind));
  response_.set_backend_name(route_.backend->name);
  response_.set_backend_mode(route_.backend->description.mode);
  for (const std::string& f : failovers_) response_.add_failovers(f);
  response_.set_batch_requests(static_cast<std::uint32_t>(batch_requests_));
  if (split()) {
    for (const PartJob& p : parts_) {
      v1::BatchPart* part = response_.add_parts();
      part->set_backend(backend_enum(p.part.route.backend->kind));
      part->set_backend_name(p.part.route.backend->name);
      part->set_first_state(static_cast<std::uint32_t>(p.part.first));
      part->set_num_states(static_cast<std::uint32_t>(p.part.n));
      part->set_compute_us(micros(p.compute));
    }
  }
  if (in_fallback_) {
    // the recomputed states' outputs over the flagged ones, in the wire encoding
    v1::ComputeResponse fallback;
    fallback_batch_.to_response(fallback, type);
    const std::size_t scalar = type == v1::SCALAR_TYPE_F32 ? sizeof(float) : sizeof(double);
    const auto nv = static_cast<std::size_t>(batch_.nv());
    for (int o : request_.outputs()) {
      const auto output = static_cast<v1::Output>(o);
      const std::size_t bytes = (is_matrix_output(output) ? nv * nv : nv) * scalar;
      std::string& to = *response_tensor(response_, output)->mutable_data();
      const std::string& from = response_tensor(fallback, output)->data();
      for (std::size_t j = 0; j < fallback_states_.size(); ++j) {
        to.replace(fallback_states_[j] * bytes, bytes, from, j * bytes, bytes);
      }
    }
    for (std::uint32_t k : fallback_states_) response_.add_fallback_states(k);
    response_.set_fallback_backend(backend_enum(fallback_route_.backend->kind));
    response_.set_fallback_precision(precision_enum(fallback_route_.precision));
  }
  v1::Timings* t = response_.mutable_timings();
  t->set_queue_us(micros(started_ - accepted_));
  t->set_compute_us(micros(compute_time_));
  t->set_total_us(micros(Clock::now() - accepted_));
  // what gRPC would do for a typed method: straight into slices, no intermediate string
  bool own_buffer = false;
  const grpc::Status s = grpc::SerializationTraits<v1::ComputeResponse>::Serialize(response_, response_bytes_,
                                                                                    &own_buffer);
  if (!s.ok()) status_ = Status(StatusCode::kInternal, prefix_ + "cannot serialize the response: " + s.error_message());
}

}  // namespace rbdgrad::server
