// ComputeStream: one long-lived bidirectional stream of ComputeRequests (an MPC loop sends one per
// control step). Requests are read ahead while earlier ones compute (up to kMaxPipelined at once)
// and answered strictly in order. A request that fails finishes the stream with its status, after
// the responses to the requests before it; the requests after it are not answered. When the
// daemon stops, an idle stream is finished UNAVAILABLE at once, a busy one after its last
// response.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_set>

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/server_callback.h>

#include "access_control.hpp"
#include "compute_call.hpp"

namespace rbdgrad::server {

class ComputeStreamReactor;

// The live streams, so that a stopping daemon can finish them instead of waiting for clients that
// never close. Thread-safe.
class StreamRegistry {
 public:
  /// Marks the service as stopping and finishes every idle stream (busy ones finish once idle).
  void shutdown();
  bool stopping() const;
  /// No stream is open: every one has finished and gRPC is done with it.
  bool empty() const;

 private:
  friend class ComputeStreamReactor;
  // false when already stopping: the new stream then finishes at once
  bool add(ComputeStreamReactor* stream);
  void remove(ComputeStreamReactor* stream);

  mutable std::mutex mutex_;
  std::unordered_set<ComputeStreamReactor*> streams_;
  bool stopping_ = false;
};

class ComputeStreamReactor final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  // requests of one stream read ahead and computing at once
  static constexpr std::size_t kMaxPipelined = 4;

  /// Starts reading. Deletes itself when gRPC is done with the stream (OnDone). `access` (may be
  /// null) holds each message to the limits of `client` (AccessControl::identify's).
  ComputeStreamReactor(ComputeContext& context, StreamRegistry& registry, AccessControl* access = nullptr,
                       std::shared_ptr<AccessControl::Client> client = nullptr);

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  class Call;
  // what to start once the lock is released: gRPC may run a reaction inline in Start*/Finish
  struct Actions {
    bool read = false;
    Call* write = nullptr;
    std::optional<grpc::Status> finish;
  };

  ~ComputeStreamReactor() override = default;
  // under mutex_: what the state allows next; takes a reference for act()
  Actions next_actions();
  // outside mutex_: performs `a`, then drops the reference (which may delete this)
  void act(Actions a);
  void unref();
  void call_done(Call* call);
  void stop();  // the daemon is stopping (StreamRegistry::shutdown)
  void fail(grpc::Status status);  // under mutex_: ends the stream with `status` (the first wins)

  ComputeContext& context_;
  StreamRegistry& registry_;
  AccessControl* const access_;
  const std::shared_ptr<AccessControl::Client> client_;
  grpc::ByteBuffer read_buffer_;  // the message being read; touched only while no read is pending

  std::mutex mutex_;
  std::deque<std::unique_ptr<Call>> pending_;  // in request order: computing, done, or being written
  std::size_t running_ = 0;                    // submitted and not yet complete
  std::int64_t next_index_ = 0;                // of the next message read
  bool read_pending_ = false;
  bool write_pending_ = false;
  bool reads_done_ = false;   // the client half-closed, or reading failed
  bool stopping_ = false;     // the daemon is stopping
  bool broken_ = false;       // a request failed: read no more (the stream ends at that request)
  bool finish_issued_ = false;
  std::optional<grpc::Status> final_status_;  // an error (or cancellation) ends the stream with it
  int refs_ = 0;              // act() calls under way: OnDone waits for them before deleting
  bool done_ = false;         // OnDone has run

  friend class StreamRegistry;
};

}  // namespace rbdgrad::server
