// A compute request's preparation (gRPC thread) and execution (pool thread or inline).
#include "compute_call.hpp"

#include <algorithm>
#include <exception>
#include <limits>
#include <string_view>

#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include "proto_enums.hpp"

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

std::uint64_t micros(ComputeCall::Clock::duration d) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(d).count();
  return us > 0 ? static_cast<std::uint64_t>(us) : 0;
}

Status with_prefix(const std::string& prefix, const Status& s) { return {s.code(), prefix + s.message()}; }

}  // namespace

ComputeContext::Admission ComputeContext::admit() noexcept {
  if (stopping_.load(std::memory_order_relaxed)) return Admission::kShuttingDown;
  if (in_flight_.fetch_add(1, std::memory_order_relaxed) >= limits_.max_concurrent_requests) {
    in_flight_.fetch_sub(1, std::memory_order_relaxed);
    return Admission::kTooManyInFlight;
  }
  return Admission::kAdmitted;
}

Status ComputeCall::prepare(const grpc::ByteBuffer& message, const ComputeContext& context,
                            std::int64_t stream_index) {
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

  const ServedModel* model = context.models().find(request_.model());
  if (model == nullptr) {
    return not_found(prefix_ + "model '" + request_.model() + "' is not loaded (loaded models: " +
                     context.models().names() + ")");
  }
  std::string_view backend;
  if (!backend_name(request_.backend(), backend)) {
    return invalid_argument(prefix_ + "backend has unknown value " + std::to_string(request_.backend()));
  }
  std::uint32_t precision = 0;
  if (!precision_flag(request_.precision(), precision)) {
    return invalid_argument(prefix_ + "precision has unknown value " + std::to_string(request_.precision()));
  }
  if (Status s = context.backends().route(*model, backend, precision, route_); !s) return with_prefix(prefix_, s);

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
  return Status::ok();
}

void ComputeCall::run(PluginInstance& instance) noexcept {
  try {
    const Clock::time_point started = Clock::now();
    const Status computed = instance.compute(batch_.batch());
    const Clock::time_point finished = Clock::now();
    if (!computed) {
      // a per-state failure fails the request: the plugin's message names the state
      status_ = with_prefix(prefix_, computed);
    } else {
      batch_.to_response(response_, request_.output_type());
      response_.set_backend(backend_enum(route_.backend->name));
      v1::Timings* t = response_.mutable_timings();
      t->set_queue_us(micros(started - accepted_));
      t->set_compute_us(micros(finished - started));
      t->set_total_us(micros(Clock::now() - accepted_));
      // what gRPC would do for a typed method: straight into slices, no intermediate string
      bool own_buffer = false;
      const grpc::Status s = grpc::SerializationTraits<v1::ComputeResponse>::Serialize(response_, response_bytes_,
                                                                                        &own_buffer);
      if (!s.ok()) status_ = Status(StatusCode::kInternal, prefix_ + "cannot serialize the response: " + s.error_message());
    }
  } catch (const std::exception& e) {
    status_ = Status(StatusCode::kInternal, prefix_ + "unexpected error: " + e.what());
  } catch (...) {
    status_ = Status(StatusCode::kInternal, prefix_ + "unexpected error");
  }
  complete();
}

}  // namespace rbdgrad::server
