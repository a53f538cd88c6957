// The gRPC callers of service_load (see grpc_callers.hpp): one template for unary calls and one
// for streams, instantiated for the Dynamics and the Echo service.
#include "grpc_callers.hpp"

#include <chrono>
#include <string>

namespace rbdgrad::bench {
namespace {

// "UNIMPLEMENTED (12)": gRPC's code names, which grpc::Status cannot print itself
std::string code_text(grpc::StatusCode code) {
  static constexpr const char* kNames[] = {"OK", "CANCELLED", "UNKNOWN", "INVALID_ARGUMENT", "DEADLINE_EXCEEDED",
                                           "NOT_FOUND", "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED",
                                           "FAILED_PRECONDITION", "ABORTED", "OUT_OF_RANGE", "UNIMPLEMENTED",
                                           "INTERNAL", "UNAVAILABLE", "DATA_LOSS", "UNAUTHENTICATED"};
  const int c = static_cast<int>(code);
  return (c >= 0 && c <= 16 ? std::string(kNames[c]) + " " : std::string()) + "(" + std::to_string(c) + ")";
}

// a failed RPC as a Status: the gRPC code and the server's message
Status rpc_error(const char* what, const grpc::Status& s) {
  return Status(StatusCode::kInternal,
                std::string(what) + " failed: gRPC status " + code_text(s.error_code()) + ": " + s.error_message());
}

bool timings_of(const v1::ComputeResponse& r, ServerTimings& out) {
  if (!r.has_timings()) return false;
  out = {static_cast<double>(r.timings().queue_us()), static_cast<double>(r.timings().compute_us()),
         static_cast<double>(r.timings().total_us())};
  return true;
}
bool timings_of(const EchoResponse&, ServerTimings&) { return false; }

// the generated stub's synchronous unary method, e.g. &v1::Dynamics::Stub::Compute
template <class Stub, class Req, class Resp>
using UnaryMethod = grpc::Status (Stub::*)(grpc::ClientContext*, const Req&, Resp*);

template <class Stub, class Req, class Resp>
class UnaryCaller final : public Caller {
 public:
  UnaryCaller(Stub& stub, UnaryMethod<Stub, Req, Resp> method, const Req& request, ResponseCheck<Resp> check)
      : stub_(stub), method_(method), request_(request), check_(std::move(check)) {}

  Status call() override {
    grpc::ClientContext context;
    const grpc::Status s = (stub_.*method_)(&context, request_, &response_);
    return s.ok() ? Status::ok() : rpc_error("unary call", s);
  }
  Status check() const override { return check_(response_); }
  Status finish() override { return Status::ok(); }
  bool server_timings(ServerTimings& out) const override { return timings_of(response_, out); }

 private:
  Stub& stub_;
  UnaryMethod<Stub, Req, Resp> method_;
  const Req& request_;
  ResponseCheck<Resp> check_;
  Resp response_;  // reused: parsing into it keeps the payload strings' capacity
};

// the generated stub's synchronous bidi method, e.g. &v1::Dynamics::Stub::ComputeStream
template <class Stub, class Req, class Resp>
using StreamMethod = std::unique_ptr<grpc::ClientReaderWriter<Req, Resp>> (Stub::*)(grpc::ClientContext*);

template <class Stub, class Req, class Resp>
class StreamCaller final : public Caller {
 public:
  StreamCaller(Stub& stub, StreamMethod<Stub, Req, Resp> method, const Req& request, ResponseCheck<Resp> check)
      : request_(request), check_(std::move(check)), stream_((stub.*method)(&context_)) {}
  ~StreamCaller() override {
    if (!finished_) context_.TryCancel();  // an error ended the run: do not wait for the server
  }

  Status call() override {
    if (finished_) return Status(StatusCode::kInternal, "stream already finished");
    if (!stream_->Write(request_)) return finish_with("stream write");
    if (!stream_->Read(&response_)) return finish_with("stream read");
    return Status::ok();
  }
  Status check() const override { return check_(response_); }
  bool server_timings(ServerTimings& out) const override { return timings_of(response_, out); }
  Status finish() override {
    if (finished_) return Status::ok();
    stream_->WritesDone();
    // a response after the half-close is a protocol error of the server
    Resp extra;
    if (stream_->Read(&extra)) {
      context_.TryCancel();
      finished_ = true;
      stream_->Finish();
      return Status(StatusCode::kInternal, "stream: a response nobody asked for");
    }
    finished_ = true;
    const grpc::Status s = stream_->Finish();
    return s.ok() ? Status::ok() : rpc_error("stream", s);
  }

 private:
  // the stream broke: its final status says why
  Status finish_with(const char* what) {
    finished_ = true;
    const grpc::Status s = stream_->Finish();
    return rpc_error(what, s.ok() ? grpc::Status(grpc::StatusCode::UNKNOWN, "stream closed early") : s);
  }

  grpc::ClientContext context_;
  const Req& request_;
  ResponseCheck<Resp> check_;
  std::unique_ptr<grpc::ClientReaderWriter<Req, Resp>> stream_;
  Resp response_;
  bool finished_ = false;
};

}  // namespace

std::shared_ptr<grpc::Channel> make_channel(const std::string& target) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  args.SetMaxSendMessageSize(-1);
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

Status wait_connected(grpc::Channel& channel, const std::string& target, double timeout_s) {
  const auto deadline = std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(timeout_s));
  if (channel.WaitForConnected(deadline)) return Status::ok();
  return Status(StatusCode::kNotFound, "cannot connect to " + target + " within " + std::to_string(static_cast<int>(timeout_s)) + " s");
}

std::unique_ptr<Caller> make_dynamics_caller(v1::Dynamics::Stub& stub, CallMode mode, const v1::ComputeRequest& request,
                                             ResponseCheck<v1::ComputeResponse> check) {
  using Stub = v1::Dynamics::Stub;
  using Req = v1::ComputeRequest;
  using Resp = v1::ComputeResponse;
  if (mode == CallMode::kUnary) return std::make_unique<UnaryCaller<Stub, Req, Resp>>(stub, &Stub::Compute, request, std::move(check));
  return std::make_unique<StreamCaller<Stub, Req, Resp>>(stub, &Stub::ComputeStream, request, std::move(check));
}

std::unique_ptr<Caller> make_echo_caller(Echo::Stub& stub, CallMode mode, const EchoRequest& request,
                                         ResponseCheck<EchoResponse> check) {
  using Stub = Echo::Stub;
  if (mode == CallMode::kUnary)
    return std::make_unique<UnaryCaller<Stub, EchoRequest, EchoResponse>>(stub, &Stub::Unary, request, std::move(check));
  return std::make_unique<StreamCaller<Stub, EchoRequest, EchoResponse>>(stub, &Stub::Stream, request, std::move(check));
}

}  // namespace rbdgrad::bench
