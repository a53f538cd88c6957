// A stand-in for rbdgradd in the client tests: the Dynamics service on an ephemeral loopback port.
// It records every ComputeRequest it receives and answers with values computed from the request's
// inputs by fake_output_value, so a test can check both what was sent and how the result maps
// states and elements. Special model names trigger failures:
//   "broken"  -> INVALID_ARGUMENT kBrokenMessage      "unknown" -> NOT_FOUND kUnknownMessage
//   "slow"    -> answers after 5 s unless cancelled    "short"   -> every output one value short
// Requests are checked like the daemon does (N >= 1, input sizes, at least one output, no NaN in q:
// INVALID_ARGUMENT "state k: field 'q' element i is not finite (nan)").
// fail_next(k) makes the next k calls of Compute, ComputeStream, ListModels and GetServerInfo fail
// at once with UNAVAILABLE (or another code), as a server that is going away would.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <grpcpp/server.h>

#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad::testing {

inline constexpr const char* kBrokenMessage = "request 'r-broken': state 1: field 'q' element 2 is not finite (nan)";
inline constexpr const char* kUnknownMessage = "model 'unknown' is not loaded (loaded: iiwa14, panda)";
// canned server timings of every response
inline constexpr std::uint64_t kQueueUs = 7, kComputeUs = 11, kTotalUs = 23;

/// The value the fake puts in output `o` (a proto Output) for state k, element (i, j) (j = 0 for
/// vectors), from that state's inputs q, qd, u (nv values each).
double fake_output_value(rbdgrad::v1::Output o, const double* q, const double* qd, const double* u, int i, int j);

class FakeDynamicsService final : public rbdgrad::v1::Dynamics::Service {
 public:
  grpc::Status Compute(grpc::ServerContext* ctx, const rbdgrad::v1::ComputeRequest* req,
                       rbdgrad::v1::ComputeResponse* resp) override;
  grpc::Status ComputeStream(
      grpc::ServerContext* ctx,
      grpc::ServerReaderWriter<rbdgrad::v1::ComputeResponse, rbdgrad::v1::ComputeRequest>* stream) override;
  grpc::Status ListModels(grpc::ServerContext* ctx, const rbdgrad::v1::ListModelsRequest* req,
                          rbdgrad::v1::ListModelsResponse* resp) override;
  grpc::Status GetModel(grpc::ServerContext* ctx, const rbdgrad::v1::GetModelRequest* req,
                        rbdgrad::v1::GetModelResponse* resp) override;
  grpc::Status GetServerInfo(grpc::ServerContext* ctx, const rbdgrad::v1::GetServerInfoRequest* req,
                             rbdgrad::v1::GetServerInfoResponse* resp) override;
  // one scene, "reach" (made from "twolink", one joint locked, computes qdd and d qdd/d q)
  grpc::Status ListScenes(grpc::ServerContext* ctx, const rbdgrad::v1::ListScenesRequest* req,
                          rbdgrad::v1::ListScenesResponse* resp) override;
  grpc::Status GetScene(grpc::ServerContext* ctx, const rbdgrad::v1::GetSceneRequest* req,
                        rbdgrad::v1::Scene* resp) override;
  // records the request and answers "reach" under the request's name (ALREADY_EXISTS for the
  // name "twolink", a model's); may fail as injected (fail_next)
  grpc::Status RegisterScene(grpc::ServerContext* ctx, const rbdgrad::v1::RegisterSceneRequest* req,
                             rbdgrad::v1::Scene* resp) override;
  // The RegisterScene requests received so far (failed ones included), in order.
  std::vector<rbdgrad::v1::RegisterSceneRequest> registrations() const;

  // Copies of the compute requests received so far (unary and stream), in arrival order.
  std::vector<rbdgrad::v1::ComputeRequest> received() const;
  // Time left until the deadline of the last call, as the server saw it on arrival.
  std::chrono::milliseconds last_time_left() const;
  int stream_count() const;

  // The next `count` calls of Compute, ComputeStream, ListModels, GetServerInfo or RegisterScene
  // fail with `code` ("injected failure") before anything else.
  void fail_next(int count, grpc::StatusCode code = grpc::StatusCode::UNAVAILABLE);
  // When each call of those five arrived (failed ones included), in order.
  std::vector<std::chrono::steady_clock::time_point> call_times() const;

 private:
  grpc::Status answer(grpc::ServerContext* ctx, const rbdgrad::v1::ComputeRequest& req,
                      rbdgrad::v1::ComputeResponse& resp);

  // records the call; the injected failure, if one is left, else OK
  grpc::Status injected();

  mutable std::mutex mutex_;
  int failures_left_ = 0;
  grpc::StatusCode failure_code_ = grpc::StatusCode::UNAVAILABLE;
  std::vector<std::chrono::steady_clock::time_point> call_times_;
  std::vector<rbdgrad::v1::ComputeRequest> received_;
  std::vector<rbdgrad::v1::RegisterSceneRequest> registrations_;
  std::chrono::milliseconds last_time_left_{0};
  int streams_ = 0;
};

// The fake service served on 127.0.0.1:<ephemeral port> until destroyed.
class FakeServer {
 public:
  FakeServer();
  ~FakeServer();
  const std::string& address() const { return address_; }
  FakeDynamicsService& service() { return service_; }

 private:
  FakeDynamicsService service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

// An address where nothing listens (a port bound and released).
std::string unused_address();

}  // namespace rbdgrad::testing
