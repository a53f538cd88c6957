// ComputeSession: one ComputeStream driven synchronously from the caller's thread (no thread
// hop per step), with a per-step deadline enforced by a gRPC alarm that cancels the stream.
#include <grpcpp/alarm.h>

#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "client_impl.hpp"
#include "compute_result_impl.hpp"
#include "request_encoding.hpp"

namespace rbdgrad {

namespace detail {

// The stream and what a step's timeout alarm touches. The alarm's callback, which may run on a
// gRPC thread after the step (or the session) has ended, sees it through a weak reference.
struct StreamCall {
  grpc::ClientContext ctx;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ComputeRequest, v1::ComputeResponse>> stream;
  std::mutex mutex;
  std::uint64_t serial = 0;  // number of the step in progress, or of the last one
  bool in_step = false;
  bool timed_out = false;

  std::uint64_t begin_step() {
    std::lock_guard lock(mutex);
    in_step = true;
    return ++serial;
  }
  void end_step() {
    std::lock_guard lock(mutex);
    in_step = false;
  }
  // The alarm of step `s` fired: cancel only if that very step is still waiting, so that a step
  // which finished just in time does not lose the stream.
  void expire(std::uint64_t s) {
    std::lock_guard lock(mutex);
    if (!in_step || serial != s) return;
    timed_out = true;
    ctx.TryCancel();
  }
};

}  // namespace detail

namespace {

using Clock = std::chrono::steady_clock;

std::string milliseconds_text(std::chrono::nanoseconds t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g ms", std::chrono::duration<double, std::milli>(t).count());
  return buf;
}

// Arms the step's deadline; destroying the guard disarms it.
class StepDeadline {
 public:
  StepDeadline(const std::shared_ptr<detail::StreamCall>& call, std::chrono::nanoseconds timeout)
      : call_(*call), serial_(call->begin_step()) {
    // weak: the callback runs on a gRPC thread, which must not end up holding the stream's (and
    // so the channel's) last reference once the session is gone
    alarm_.Set(detail::deadline_after(timeout), [weak = std::weak_ptr<detail::StreamCall>(call), s = serial_](bool fired) {
      if (!fired) return;
      if (const std::shared_ptr<detail::StreamCall> live = weak.lock()) live->expire(s);
    });
  }
  ~StepDeadline() {
    call_.end_step();
    alarm_.Cancel();
  }
  StepDeadline(const StepDeadline&) = delete;
  StepDeadline& operator=(const StepDeadline&) = delete;

 private:
  detail::StreamCall& call_;
  std::uint64_t serial_;
  grpc::Alarm alarm_;
};

}  // namespace

struct ComputeSession::State {
  std::shared_ptr<detail::StreamCall> call;
  v1::ComputeRequest msg;                  // reused by every step
  std::chrono::nanoseconds step_timeout{};
  bool open = true;
  RpcStatus final_status;                  // once closed: how the stream ended

  // Collects the stream's status after it failed or was closed, and closes the session.
  RpcStatus finish(std::chrono::nanoseconds timeout) {
    const grpc::Status st = call->stream->Finish();
    open = false;
    if (call->timed_out)
      final_status = {RpcCode::kDeadlineExceeded,
                      "client: a session step exceeded its timeout of " + milliseconds_text(timeout) +
                          "; the session is closed"};
    else
      final_status = detail::from_grpc(st);
    return final_status;
  }
};

ComputeSession::ComputeSession() = default;
ComputeSession::ComputeSession(std::unique_ptr<State> state) : state_(std::move(state)) {}
ComputeSession::ComputeSession(ComputeSession&&) noexcept = default;

ComputeSession& ComputeSession::operator=(ComputeSession&& other) noexcept {
  if (this != &other) {
    if (is_open()) (void)close();
    state_ = std::move(other.state_);
    result_ = std::move(other.result_);
  }
  return *this;
}

ComputeSession::~ComputeSession() {
  if (is_open()) (void)close();
}

bool ComputeSession::is_open() const noexcept { return state_ && state_->open; }

RpcStatus ComputeSession::step(const ComputeRequest& req, ComputeResult& out) {
  const Clock::time_point start = Clock::now();
  ComputeResult::Impl& result = detail::ResultAccess::reset_for_call(out);
  if (!is_open()) {
    std::string why = "client: the session is closed";
    if (state_ && !state_->final_status) why += " (it ended with " + state_->final_status.to_string() + ")";
    return {RpcCode::kFailedPrecondition, why};
  }
  State& s = *state_;
  if (RpcStatus st = detail::encode_request(req, s.msg); !st) return st;
  const std::chrono::nanoseconds timeout = req.timeout.value_or(s.step_timeout);
  bool ok = false;
  {
    StepDeadline deadline(s.call, timeout);
    ok = s.call->stream->Write(s.msg) && s.call->stream->Read(&result.response);
  }
  // the server ends the stream at a failed request: its status says why
  if (!ok) return s.finish(timeout);
  return detail::adopt_response(detail::expected_result(req), result,
                                std::chrono::duration<double, std::micro>(Clock::now() - start).count());
}

const ComputeResult& ComputeSession::step(const ComputeRequest& req) {
  if (RpcStatus st = step(req, result_); !st) throw ClientError(std::move(st));
  return result_;
}

RpcStatus ComputeSession::close() {
  if (!state_) return {RpcCode::kFailedPrecondition, "client: the session was never opened"};
  State& s = *state_;
  if (!s.open) return s.final_status;
  StepDeadline deadline(s.call, s.step_timeout);
  s.call->stream->WritesDone();
  return s.finish(s.step_timeout);
}

ComputeSession Client::open_session(const SessionOptions& options) const {
  auto state = std::make_unique<ComputeSession::State>();
  state->call = std::make_shared<detail::StreamCall>();
  state->step_timeout = options.step_timeout.value_or(impl_->options.default_timeout);
  grpc::ClientContext& ctx = state->call->ctx;
  if (options.lifetime) ctx.set_deadline(detail::deadline_after(*options.lifetime));
  ctx.set_wait_for_ready(impl_->options.wait_for_ready);
  impl_->add_token(ctx);
  // the stream's headers leave with the first request: opening never blocks on the network
  ctx.set_initial_metadata_corked(true);
  state->call->stream = impl_->stub->ComputeStream(&ctx);
  return ComputeSession(std::move(state));
}

}  // namespace rbdgrad
