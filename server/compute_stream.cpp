// The ComputeStream reactor: read-ahead, in-order responses, and its end (client close, error,
// cancellation or daemon stop).
#include "compute_stream.hpp"

#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "grpc_status.hpp"

namespace rbdgrad::server {

// One request of the stream: its response bytes live here until written.
class ComputeStreamReactor::Call final : public ComputeCall {
 public:
  Call(ComputeStreamReactor& stream, Clock::time_point accepted) : ComputeCall(accepted, &bytes), stream_(stream) {}

  grpc::ByteBuffer bytes;  // the serialized response, written from here
  bool done = false;       // run() has finished, or the call was refused (under the stream's mutex)
  bool admitted = false;   // counts against max_concurrent_requests until it leaves the stream
  AccessControl::Ticket ticket;  // its client's place among client_max_concurrent, as long as it lives
  std::optional<grpc::Status> refused;  // refused before running: the stream ends here, in order

 private:
  void complete() noexcept override { stream_.call_done(this); }

  ComputeStreamReactor& stream_;
};

// --- StreamRegistry ---

bool StreamRegistry::add(ComputeStreamReactor* stream) {
  std::lock_guard lock(mutex_);
  if (stopping_) return false;
  streams_.insert(stream);
  return true;
}

void StreamRegistry::remove(ComputeStreamReactor* stream) {
  std::lock_guard lock(mutex_);
  streams_.erase(stream);
}

bool StreamRegistry::empty() const {
  std::lock_guard lock(mutex_);
  return streams_.empty();
}

bool StreamRegistry::stopping() const {
  std::lock_guard lock(mutex_);
  return stopping_;
}

void StreamRegistry::shutdown() {
  std::vector<ComputeStreamReactor*> streams;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    streams.assign(streams_.begin(), streams_.end());
    // a reference each, taken while the registry still holds them: none can be deleted meanwhile
    for (ComputeStreamReactor* s : streams) {
      std::lock_guard stream_lock(s->mutex_);
      ++s->refs_;
    }
  }
  for (ComputeStreamReactor* s : streams) {
    s->stop();
    s->unref();
  }
}

// --- ComputeStreamReactor ---

ComputeStreamReactor::ComputeStreamReactor(ComputeContext& context, StreamRegistry& registry, AccessControl* access,
                                           std::shared_ptr<AccessControl::Client> client)
    : context_(context), registry_(registry), access_(access), client_(std::move(client)) {
  const bool open = registry_.add(this);
  Actions a;
  {
    std::lock_guard lock(mutex_);
    stopping_ = !open;
    a = next_actions();
  }
  act(std::move(a));
}

void ComputeStreamReactor::fail(grpc::Status status) {
  if (!final_status_) final_status_ = std::move(status);
}

ComputeStreamReactor::Actions ComputeStreamReactor::next_actions() {
  Actions a;
  ++refs_;
  // the oldest request goes out first; a failed one ends the stream after the ones before it,
  // and once the stream has ended, finished calls are dropped
  while (!write_pending_ && !pending_.empty() && pending_.front()->done) {
    Call* head = pending_.front().get();
    if (!final_status_ && !head->refused && head->status().is_ok()) {
      a.write = head;
      write_pending_ = true;
      break;
    }
    if (!final_status_) {
      if (head->refused) {
        fail(*head->refused);
      } else {
        spdlog::debug("stream request failed: {}", head->status().to_string());
        fail(to_grpc_status(head->status()));
      }
    }
    if (head->admitted) context_.release();
    pending_.pop_front();
  }
  if (!final_status_ && !broken_ && !stopping_ && !reads_done_ && !read_pending_ && !finish_issued_ &&
      pending_.size() < kMaxPipelined) {
    a.read = true;
    read_pending_ = true;
  }
  // the end: every accepted request answered (or dropped after an error) and nothing in flight
  if (!finish_issued_ && !write_pending_ && running_ == 0 && pending_.empty() &&
      (final_status_ || reads_done_ || stopping_)) {
    finish_issued_ = true;
    if (final_status_) {
      a.finish = *final_status_;
    } else if (reads_done_) {
      a.finish = grpc::Status::OK;
    } else {
      a.finish = grpc::Status(grpc::StatusCode::UNAVAILABLE, "rbdgradd is shutting down");
    }
  }
  return a;
}

void ComputeStreamReactor::act(Actions a) {
  // read first: the next request arrives while this one is written
  if (a.read) StartRead(&read_buffer_);
  if (a.write != nullptr) StartWrite(&a.write->bytes);
  if (a.finish) Finish(std::move(*a.finish));
  unref();
}

void ComputeStreamReactor::unref() {
  bool destroy = false;
  {
    std::lock_guard lock(mutex_);
    destroy = --refs_ == 0 && done_;
  }
  if (destroy) delete this;
}

void ComputeStreamReactor::OnReadDone(bool ok) {
  const auto accepted = ComputeCall::Clock::now();
  std::int64_t index = 0;
  bool closing = false;
  Actions a;
  {
    std::lock_guard lock(mutex_);
    if (!ok || finish_issued_) {
      // the client half-closed (or the stream is over): answer what is pending, then finish
      read_pending_ = false;
      reads_done_ = true;
      closing = true;
      a = next_actions();
    } else {
      index = next_index_++;
    }
  }
  if (closing) {
    act(std::move(a));
    return;
  }

  // read_pending_ stays set while read_buffer_ is parsed: no other thread starts a read into it
  auto call = std::make_unique<Call>(*this, accepted);
  // the client's own limits first: one client at its limit must not take the others' places
  grpc::Status limited = grpc::Status::OK;
  if (access_ != nullptr)
    limited = access_->admit(client_, &call->ticket, "stream message " + std::to_string(index) + ": ");
  const ComputeContext::Admission admission =
      limited.ok() ? context_.admit() : ComputeContext::Admission::kTooManyInFlight;
  call->admitted = admission == ComputeContext::Admission::kAdmitted;
  if (!limited.ok()) {
    call->refused = std::move(limited);
  } else if (admission == ComputeContext::Admission::kTooManyInFlight) {
    if (Metrics* m = context_.metrics()) m->record_rejection("max_concurrent_requests");
    call->refused = grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                 "stream message " + std::to_string(index) +
                                     ": too many requests in flight (limit max_concurrent_requests = " +
                                     std::to_string(context_.limits().max_concurrent_requests) + ")");
  } else if (admission == ComputeContext::Admission::kShuttingDown) {
    call->refused = grpc::Status(grpc::StatusCode::UNAVAILABLE,
                                 "stream message " + std::to_string(index) + ": " + kShuttingDownMessage);
  } else if (Status s = call->prepare(read_buffer_, context_, index); !s) {
    spdlog::debug("stream request refused: {}", s.to_string());
    call->record_refusal(s);
    call->refused = to_grpc_status(s);
  }
  read_buffer_.Clear();

  Call* to_submit = nullptr;
  {
    std::lock_guard lock(mutex_);
    read_pending_ = false;
    if (final_status_ || broken_) {
      // after a request that fails: not started, not answered (the client gets that error)
      if (call->admitted) context_.release();
    } else if (call->refused) {
      // answered in order: the responses before it go out first, then the stream ends with it
      broken_ = true;
      call->done = true;
      pending_.push_back(std::move(call));
    } else {
      to_submit = call.get();
      pending_.push_back(std::move(call));
      ++running_;
    }
    a = next_actions();
    // one more reference for the submit below, so that nothing it triggers can delete this
    ++refs_;
  }
  act(std::move(a));
  if (to_submit != nullptr) to_submit->submit();
  unref();
}

void ComputeStreamReactor::call_done(Call* call) {
  Actions a;
  {
    std::lock_guard lock(mutex_);
    call->done = true;
    --running_;
    // no point reading requests that will not be answered
    if (!call->status().is_ok()) broken_ = true;
    a = next_actions();
  }
  act(std::move(a));
}

void ComputeStreamReactor::OnWriteDone(bool ok) {
  std::unique_ptr<Call> written;
  Actions a;
  {
    std::lock_guard lock(mutex_);
    write_pending_ = false;
    written = std::move(pending_.front());
    pending_.pop_front();
    if (written->admitted) context_.release();
    if (!ok) fail(grpc::Status(grpc::StatusCode::CANCELLED, "the response could not be written (client gone)"));
    a = next_actions();
  }
  written.reset();  // outside the lock: freeing a large response takes a moment
  act(std::move(a));
}

void ComputeStreamReactor::OnCancel() {
  Actions a;
  {
    std::lock_guard lock(mutex_);
    fail(grpc::Status(grpc::StatusCode::CANCELLED, "the stream was cancelled"));
    a = next_actions();
  }
  act(std::move(a));
}

void ComputeStreamReactor::stop() {
  Actions a;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    a = next_actions();
  }
  act(std::move(a));
}

void ComputeStreamReactor::OnDone() {
  registry_.remove(this);
  bool destroy = false;
  {
    std::lock_guard lock(mutex_);
    done_ = true;
    destroy = refs_ == 0;
  }
  if (destroy) delete this;
}

}  // namespace rbdgrad::server
