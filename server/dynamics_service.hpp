// The rbdgrad.v1.Dynamics service on gRPC's callback API: a thin adapter from RPCs to the model
// registry, the backends and ComputeCall. Compute and ComputeStream are registered as raw
// (ByteBuffer) methods so that a message that does not parse is the client's INVALID_ARGUMENT
// rather than gRPC's INTERNAL; the other methods are typed.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/server_callback.h>

#include "access_control.hpp"
#include "backend_pool.hpp"
#include "compute_call.hpp"
#include "compute_stream.hpp"
#include "config.hpp"
#include "model_registry.hpp"
#include "scene_registrar.hpp"
#include "scheduler.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad::server {

using DynamicsServiceBase = rbdgrad::v1::Dynamics::WithRawCallbackMethod_Compute<
    rbdgrad::v1::Dynamics::WithRawCallbackMethod_ComputeStream<rbdgrad::v1::Dynamics::WithCallbackMethod_ListModels<
        rbdgrad::v1::Dynamics::WithCallbackMethod_GetModel<rbdgrad::v1::Dynamics::WithCallbackMethod_ListScenes<
            rbdgrad::v1::Dynamics::WithCallbackMethod_GetScene<rbdgrad::v1::Dynamics::WithCallbackMethod_GetServerInfo<
                rbdgrad::v1::Dynamics::WithCallbackMethod_Calibrate<
                    rbdgrad::v1::Dynamics::WithCallbackMethod_RegisterScene<rbdgrad::v1::Dynamics::Service>>>>>>>>>;

class DynamicsService final : public DynamicsServiceBase {
 public:
  /// `models`, `backends`, `scheduler`, `metrics`, `access` and `registrar` (each of the last
  /// three may be null) must outlive the service; `version` is GetServerInfo's;
  /// `fixed_point_fallback` is ServerConfig's ("" = none). `access` checks every call's token and
  /// per-client limits first (null: no check). `registrar` registers scenes (null: RegisterScene
  /// is UNIMPLEMENTED).
  DynamicsService(const ModelRegistry& models, const BackendPool& backends, Scheduler& scheduler,
                  const LimitsConfig& limits, std::string version, std::string fixed_point_fallback = "",
                  Metrics* metrics = nullptr, Coalescer* coalescer = nullptr, AccessControl* access = nullptr,
                  SceneRegistrar* registrar = nullptr);

  /// The daemon is stopping: new compute requests are refused (UNAVAILABLE), idle streams finish
  /// now, busy ones after their last response. Calls already accepted complete normally.
  void begin_shutdown() {
    context_.begin_shutdown();
    streams_.shutdown();
  }

  /// Every accepted compute request has been answered and every stream has ended.
  bool drained() const { return context_.in_flight() == 0 && streams_.empty(); }

  /// Compute requests accepted and not yet answered (unary and streamed).
  std::int64_t in_flight() const noexcept { return context_.in_flight(); }

  grpc::ServerUnaryReactor* Compute(grpc::CallbackServerContext* context, const grpc::ByteBuffer* request,
                                    grpc::ByteBuffer* response) override;
  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* ComputeStream(
      grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* ListModels(grpc::CallbackServerContext* context, const rbdgrad::v1::ListModelsRequest* request,
                                       rbdgrad::v1::ListModelsResponse* response) override;
  grpc::ServerUnaryReactor* GetModel(grpc::CallbackServerContext* context, const rbdgrad::v1::GetModelRequest* request,
                                     rbdgrad::v1::GetModelResponse* response) override;
  grpc::ServerUnaryReactor* ListScenes(grpc::CallbackServerContext* context, const rbdgrad::v1::ListScenesRequest* request,
                                       rbdgrad::v1::ListScenesResponse* response) override;
  grpc::ServerUnaryReactor* GetScene(grpc::CallbackServerContext* context, const rbdgrad::v1::GetSceneRequest* request,
                                     rbdgrad::v1::Scene* response) override;
  grpc::ServerUnaryReactor* GetServerInfo(grpc::CallbackServerContext* context,
                                          const rbdgrad::v1::GetServerInfoRequest* request,
                                          rbdgrad::v1::GetServerInfoResponse* response) override;
  // registers on the calling gRPC thread (SceneRegistrar), as Calibrate calibrates: the
  // instances and the scene's calibration sweep (with calibrate "start" and nothing in the file)
  // take about a second on the CPU
  grpc::ServerUnaryReactor* RegisterScene(grpc::CallbackServerContext* context,
                                          const rbdgrad::v1::RegisterSceneRequest* request,
                                          rbdgrad::v1::Scene* response) override;
  // runs the calibration on the calling gRPC thread: an operator's call, seconds long
  grpc::ServerUnaryReactor* Calibrate(grpc::CallbackServerContext* context,
                                      const rbdgrad::v1::CalibrateRequest* request,
                                      rbdgrad::v1::CalibrateResponse* response) override;

 private:
  // The token and the client's request rate, for a call other than Compute: false (and `reactor`
  // finished with the refusal) when refused.
  bool admit_call(grpc::CallbackServerContext* context, grpc::ServerUnaryReactor* reactor);

  AccessControl* const access_;
  ComputeContext context_;
  StreamRegistry streams_;
  Scheduler& scheduler_;        // Calibrate replaces its latency models
  SceneRegistrar* const registrar_;  // null: no RegisterScene
  std::mutex calibrating_;      // one Calibrate at a time
  // the answers that never change, built once (scenes are listed at each call: they are added)
  rbdgrad::v1::ListModelsResponse list_models_;
  rbdgrad::v1::GetServerInfoResponse server_info_;
};

/// GetModel's answer for one model: joints in model order with types, parents, links and limits,
/// gravity and the summary text.
rbdgrad::v1::GetModelResponse describe_model(const ServedModel& model);

/// GetScene's answer for one scene (model.scene set): its joints as describe_model gives them,
/// what it locks, its gravity, force links and outputs.
rbdgrad::v1::Scene describe_scene(const ServedModel& scene);

/// GetServerInfo's answer: every backend tried (ready or with the reason), plus "cpu", "cuda" and
/// "fpga" as unavailable ("not configured") when they were not tried, and the limits.
rbdgrad::v1::GetServerInfoResponse describe_server(const BackendPool& backends, const LimitsConfig& limits,
                                                   const std::string& version);
/// What changes while the daemon runs, added to describe_server's answer: each backend's latency
/// models and queues, and each model's routing (crossovers, thresholds) with the policy.
void describe_scheduling(const Scheduler& scheduler, const BackendPool& backends, const ModelRegistry& models,
                         rbdgrad::v1::GetServerInfoResponse& out);

}  // namespace rbdgrad::server
