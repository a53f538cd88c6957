// The echo service of echo.proto in the two gRPC server APIs, so that the benchmark can use the
// leaner one as its transport floor: the callback API (handlers run on gRPC's own threads, the API
// rbdgradd uses) and the synchronous API (handlers run on a pool of gRPC-managed threads).
// Both answer every request with EchoResponse.payload = response_bytes zero bytes and nothing else.
#pragma once

#include <cstdint>

#include "echo.grpc.pb.h"

namespace rbdgrad::bench {

// Largest response payload a request may ask for; more is INVALID_ARGUMENT (not an allocation of
// whatever a client wrote).
inline constexpr std::uint64_t kMaxEchoResponseBytes = 1ull << 30;

class CallbackEchoService final : public Echo::CallbackService {
 public:
  grpc::ServerUnaryReactor* Unary(grpc::CallbackServerContext* context, const EchoRequest* request,
                                  EchoResponse* response) override;
  grpc::ServerBidiReactor<EchoRequest, EchoResponse>* Stream(grpc::CallbackServerContext* context) override;
};

class SyncEchoService final : public Echo::Service {
 public:
  grpc::Status Unary(grpc::ServerContext* context, const EchoRequest* request, EchoResponse* response) override;
  grpc::Status Stream(grpc::ServerContext* context,
                      grpc::ServerReaderWriter<EchoResponse, EchoRequest>* stream) override;
};

}  // namespace rbdgrad::bench
