// The echo service in the callback and the synchronous gRPC API (see echo_service.hpp).
#include "echo_service.hpp"

#include <string>

namespace rbdgrad::bench {
namespace {

// fills `response` as the request asks; an error status for an absurd size
grpc::Status answer(const EchoRequest& request, EchoResponse& response) {
  if (request.response_bytes() > kMaxEchoResponseBytes)
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "response_bytes " + std::to_string(request.response_bytes()) + " is above the limit " +
                std::to_string(kMaxEchoResponseBytes)};
  // resize() of the (reused or fresh) string: one memset, as cheap as producing bytes gets
  response.mutable_payload()->resize(request.response_bytes());
  return grpc::Status::OK;
}

// One bidirectional stream: read a request, write its response, repeat until the client closes.
// Reads and writes alternate, so at most one of each is pending, as the callback API requires.
class EchoStreamReactor final : public grpc::ServerBidiReactor<EchoRequest, EchoResponse> {
 public:
  EchoStreamReactor() { StartRead(&request_); }

  void OnReadDone(bool ok) override {
    if (!ok) {  // the client half-closed (or the call is cancelled): done
      Finish(grpc::Status::OK);
      return;
    }
    if (grpc::Status s = answer(request_, response_); !s.ok()) {
      Finish(s);
      return;
    }
    StartWrite(&response_);
  }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "echo stream: write failed"));
      return;
    }
    StartRead(&request_);
  }

  void OnDone() override { delete this; }

 private:
  EchoRequest request_;
  EchoResponse response_;  // reused: its payload keeps its capacity between messages
};

}  // namespace

grpc::ServerUnaryReactor* CallbackEchoService::Unary(grpc::CallbackServerContext* context, const EchoRequest* request,
                                                     EchoResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(answer(*request, *response));
  return reactor;
}

grpc::ServerBidiReactor<EchoRequest, EchoResponse>* CallbackEchoService::Stream(grpc::CallbackServerContext*) {
  return new EchoStreamReactor();
}

grpc::Status SyncEchoService::Unary(grpc::ServerContext*, const EchoRequest* request, EchoResponse* response) {
  return answer(*request, *response);
}

grpc::Status SyncEchoService::Stream(grpc::ServerContext*, grpc::ServerReaderWriter<EchoResponse, EchoRequest>* stream) {
  EchoRequest request;
  EchoResponse response;
  while (stream->Read(&request)) {
    if (grpc::Status s = answer(request, response); !s.ok()) return s;
    if (!stream->Write(response)) return {grpc::StatusCode::UNAVAILABLE, "echo stream: write failed"};
  }
  return grpc::Status::OK;
}

}  // namespace rbdgrad::bench
