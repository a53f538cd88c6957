// The Dynamics service's handlers.
#include "dynamics_service.hpp"

#include <algorithm>
#include <utility>

#include <spdlog/spdlog.h>

#include "grpc_status.hpp"
#include "proto_enums.hpp"
#include "scene.hpp"

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

// A unary Compute and its reactor: finishes the RPC when its job completes, and counts as in
// flight until gRPC is done with it (OnDone), i.e. until the response has gone out, so that a
// stopping daemon closes connections only after every answer has left.
class UnaryCall final : public ComputeCall, public grpc::ServerUnaryReactor {
 public:
  UnaryCall(Clock::time_point accepted, grpc::ByteBuffer* response, ComputeContext& context)
      : ComputeCall(accepted, response), context_(context) {}

  /// The caller's token and its client's limits (`access` null: none); false (and the RPC
  /// finished) when refused. The client's place is held until the call is done.
  bool admit_client(AccessControl* access, const grpc::CallbackServerContext& ctx) {
    if (access == nullptr) return true;
    std::shared_ptr<AccessControl::Client> client;
    grpc::Status st = access->identify(ctx, client);
    if (st.ok()) st = access->admit(client, &ticket_);
    if (st.ok()) return true;
    Finish(st);
    return false;
  }

  /// Counts the call against max_concurrent_requests; false (and the RPC finished) when refused.
  bool admit() {
    switch (context_.admit()) {
      case ComputeContext::Admission::kAdmitted:
        admitted_ = true;
        return true;
      case ComputeContext::Admission::kTooManyInFlight:
        if (Metrics* m = context_.metrics()) m->record_rejection("max_concurrent_requests");
        Finish({grpc::StatusCode::RESOURCE_EXHAUSTED,
                "too many requests in flight (limit max_concurrent_requests = " +
                    std::to_string(context_.limits().max_concurrent_requests) + ")"});
        return false;
      case ComputeContext::Admission::kShuttingDown:
        Finish({grpc::StatusCode::UNAVAILABLE, kShuttingDownMessage});
        return false;
    }
    return false;
  }

  // for a request refused before it ran
  void refuse(const Status& status) {
    spdlog::debug("request refused: {}", status.to_string());
    Finish(to_grpc_status(status));
  }

  void OnDone() override {
    if (admitted_) context_.release();
    delete this;
  }

 private:
  void complete() noexcept override {
    if (!status().is_ok()) spdlog::debug("request failed: {}", status().to_string());
    Finish(to_grpc_status(status()));
  }

  ComputeContext& context_;
  AccessControl::Ticket ticket_;  // the client's place among its client_max_concurrent
  bool admitted_ = false;
};

// A stream refused before its first message (no valid token): finishes at once.
class RefusedStream final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  explicit RefusedStream(grpc::Status status) { Finish(std::move(status)); }
  void OnDone() override { delete this; }
};

void add_precisions(std::uint32_t flags, v1::BackendInfo& info) {
  for (std::uint32_t p : {RBDGRAD_PRECISION_F64, RBDGRAD_PRECISION_F32, RBDGRAD_PRECISION_FIXED_Q16_16}) {
    if (flags & p) info.add_precisions(precision_enum(p));
  }
}

}  // namespace

v1::GetModelResponse describe_model(const ServedModel& served) {
  const Model& model = served.model;
  v1::GetModelResponse out;
  out.set_name(served.name);
  out.set_nv(static_cast<std::uint32_t>(model.nv));
  for (int i = 0; i < model.nv; ++i) {
    const JointInfo& j = model.joints[static_cast<std::size_t>(i)];
    v1::Joint* joint = out.add_joints();
    joint->set_name(j.name);
    joint->set_type(j.urdf_type);
    joint->set_parent(model.parent[static_cast<std::size_t>(i)]);
    joint->set_parent_link(j.parent_link);
    joint->set_child_link(j.child_link);
    joint->set_lower_limit(j.lower_limit);
    joint->set_upper_limit(j.upper_limit);
    joint->set_effort_limit(j.effort_limit);
    joint->set_velocity_limit(j.velocity_limit);
  }
  for (int k = 0; k < 3; ++k) out.add_gravity(model.gravity[k]);
  out.set_summary(served.summary);
  return out;
}

v1::Scene describe_scene(const ServedModel& served) {
  const SceneInfo& info = *served.scene;
  v1::Scene out;
  out.set_name(served.name);
  out.set_model(info.model);
  out.set_nv(static_cast<std::uint32_t>(served.model.nv));
  *out.mutable_joints() = describe_model(served).joints();
  for (const auto& [joint, value] : info.locked_joints) {
    out.add_locked_joints(joint);
    out.add_locked_values(value);
  }
  out.set_gravity(info.gravity);
  for (const std::string& link : info.force_links) out.add_force_links(link);
  for (int k = 0; k < 8; ++k)
    if (info.outputs & (1u << k)) out.add_outputs(static_cast<v1::Output>(k + 1));
  out.set_minv_supplied(info.minv_supplied);
  return out;
}

v1::GetServerInfoResponse describe_server(const BackendPool& backends, const LimitsConfig& limits,
                                          const std::string& version) {
  v1::GetServerInfoResponse out;
  out.set_version(version);
  for (const BackendState& state : backends.backends()) {
    v1::BackendInfo* info = out.add_backends();
    info->set_backend(backend_enum(state.kind));  // the kind; name says which backend of it
    info->set_name(state.name);
    info->set_ready(state.ready);
    info->set_reason(state.reason);
    info->set_mode(state.description.mode);
    info->set_device(state.description.device);
    info->set_detail(state.description.detail);
    if (!state.info.name.empty()) {
      add_precisions(state.info.precisions, *info);
      info->set_max_batch(state.info.max_batch);
    }
  }
  // the backends the API names are always listed, so that a client sees why one is missing
  for (const char* name : {"cpu", "cuda", "fpga"}) {
    const auto& all = backends.backends();
    if (std::any_of(all.begin(), all.end(), [&](const BackendState& s) { return s.name == name || s.kind == name; }))
      continue;
    v1::BackendInfo* info = out.add_backends();
    info->set_backend(backend_enum(name));
    info->set_name(name);
    info->set_ready(false);
    info->set_reason("not configured");
  }
  out.set_max_states_per_request(static_cast<std::uint32_t>(limits.max_states_per_request));
  out.set_max_message_bytes(static_cast<std::uint64_t>(limits.max_message_bytes));
  out.set_max_concurrent_requests(static_cast<std::uint32_t>(limits.max_concurrent_requests));
  return out;
}

void describe_scheduling(const Scheduler& scheduler, const BackendPool& backends, const ModelRegistry& models,
                         v1::GetServerInfoResponse& out) {
  const CalibrationTable table = scheduler.table();
  for (v1::BackendInfo& info : *out.mutable_backends()) {
    for (const CalibrationEntry& e : table.entries()) {
      if (e.backend != info.name()) continue;
      v1::LatencyModelInfo* m = info.add_latency_models();
      m->set_model(e.model);
      m->set_precision(precision_enum(e.precision));
      m->set_source(e.source);
      m->set_fixed_us(e.latency.fixed_us());
      m->set_per_state_us(e.latency.per_state_us());
      for (const LatencyModel::Point& p : e.latency.points()) {
        m->add_n(p.n);
        m->add_us(p.us);
      }
    }
    for (const auto& model : models.models()) {
      const InstancePool* pool = backends.pool(info.name(), *model);
      if (pool == nullptr) continue;
      const PoolLoad load = pool->load();
      v1::QueueInfo* q = info.add_queues();
      q->set_model(model->name);
      q->set_queued(static_cast<std::uint32_t>(load.queued));
      q->set_running(static_cast<std::uint32_t>(load.running));
      q->set_pending_us(load.pending_us);
    }
  }
  out.set_scheduler_policy(scheduler.config().policy);
  for (const auto& model : models.models()) {
    v1::RoutingInfo* r = out.add_routing();
    r->set_model(model->name);
    for (const auto& [n, backend] : scheduler.crossovers(*model, 0, std::uint64_t{1} << 20)) {
      v1::RoutingInfo::Crossover* c = r->add_crossovers();
      c->set_from_n(n);
      std::string kind = backend;
      for (const BackendState& b : backends.backends())
        if (b.name == backend) kind = b.kind;
      c->set_backend(backend_enum(kind));
      c->set_backend_name(backend);
    }
    const auto [small_n, large_n] = scheduler.thresholds(*model);
    r->set_small_n(small_n);
    r->set_large_n(large_n);
  }
}

DynamicsService::DynamicsService(const ModelRegistry& models, const BackendPool& backends, Scheduler& scheduler,
                                 const LimitsConfig& limits, std::string version, std::string fixed_point_fallback,
                                 Metrics* metrics, Coalescer* coalescer, AccessControl* access,
                                 SceneRegistrar* registrar)
    : access_(access),
      context_(models, backends, scheduler, limits, std::move(fixed_point_fallback), metrics, coalescer),
      scheduler_(scheduler),
      registrar_(registrar),
      server_info_(describe_server(backends, limits, version)) {
  for (const auto& m : models.models()) {
    if (m->scene) continue;
    v1::ModelSummary* s = list_models_.add_models();
    s->set_name(m->name);
    s->set_nv(static_cast<std::uint32_t>(m->model.nv));
    s->set_source(m->source);
  }
}

grpc::ServerUnaryReactor* DynamicsService::Compute(grpc::CallbackServerContext* context,
                                                   const grpc::ByteBuffer* request, grpc::ByteBuffer* response) {
  const auto accepted = ComputeCall::Clock::now();
  // the client's deadline on our clock; none (the far future) stays none
  ComputeCall::Clock::time_point deadline = ComputeCall::Clock::time_point::max();
  const auto client_deadline = context->deadline();
  if (client_deadline < std::chrono::system_clock::now() + std::chrono::hours(24 * 365))
    deadline = accepted + std::chrono::duration_cast<ComputeCall::Clock::duration>(client_deadline -
                                                                                   std::chrono::system_clock::now());
  // gRPC deletes nothing of ours: the call deletes itself in OnDone, which gRPC calls only after
  // this handler has returned it
  auto* call = new UnaryCall(accepted, response, context_);
  if (!call->admit_client(access_, *context) || !call->admit()) return call;
  if (Status s = call->prepare(*request, context_, -1, deadline); !s) {
    call->record_refusal(s);
    call->refuse(s);
    return call;
  }
  call->submit();  // the call finishes the RPC, maybe before submit returns
  return call;
}

grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* DynamicsService::ComputeStream(
    grpc::CallbackServerContext* context) {
  // the token once, for the whole stream; the client's limits for each message
  std::shared_ptr<AccessControl::Client> client;
  if (access_ != nullptr) {
    if (grpc::Status st = access_->identify(*context, client); !st.ok()) return new RefusedStream(std::move(st));
  }
  return new ComputeStreamReactor(context_, streams_, access_, std::move(client));
}

bool DynamicsService::admit_call(grpc::CallbackServerContext* context, grpc::ServerUnaryReactor* reactor) {
  if (access_ == nullptr) return true;
  std::shared_ptr<AccessControl::Client> client;
  grpc::Status st = access_->identify(*context, client);
  if (st.ok()) st = access_->admit(client, nullptr);
  if (st.ok()) return true;
  reactor->Finish(st);
  return false;
}

grpc::ServerUnaryReactor* DynamicsService::ListModels(grpc::CallbackServerContext* context,
                                                      const v1::ListModelsRequest* /*request*/,
                                                      v1::ListModelsResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  *response = list_models_;
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::GetModel(grpc::CallbackServerContext* context,
                                                    const v1::GetModelRequest* request,
                                                    v1::GetModelResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  const ServedModel* model = context_.models().find(request->name());
  if (model == nullptr) {
    reactor->Finish(to_grpc_status(not_found("model '" + request->name() + "' is not loaded (loaded models: " +
                                             context_.models().names() + ")")));
    return reactor;
  }
  *response = describe_model(*model);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::ListScenes(grpc::CallbackServerContext* context,
                                                      const v1::ListScenesRequest* /*request*/,
                                                      v1::ListScenesResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  // the configured ones, then the registered ones in their order
  for (const auto& m : context_.models().models())
    if (m->scene) *response->add_scenes() = describe_scene(*m);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::GetScene(grpc::CallbackServerContext* context,
                                                    const v1::GetSceneRequest* request, v1::Scene* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  const ServedModel* scene = context_.models().find_scene(request->name());
  if (scene == nullptr) {
    const std::string names = context_.models().scene_names();
    reactor->Finish(to_grpc_status(not_found("scene '" + request->name() + "' is not configured (scenes: " +
                                             (names.empty() ? std::string("none") : names) + ")")));
    return reactor;
  }
  *response = describe_scene(*scene);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::RegisterScene(grpc::CallbackServerContext* context,
                                                         const v1::RegisterSceneRequest* request,
                                                         v1::Scene* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  if (registrar_ == nullptr) {
    reactor->Finish(grpc::Status(grpc::StatusCode::UNIMPLEMENTED, "this server registers no scenes"));
    return reactor;
  }
  SceneConfig cfg;
  if (Status s = scene_config_from_request(*request, cfg); !s) {
    reactor->Finish(to_grpc_status(s));
    return reactor;
  }
  const SceneRegistration r =
      registrar_->register_scene(cfg, [](const std::string& line) { spdlog::info("{}", line); });
  if (r.outcome == RegistrationOutcome::kAlreadyRegistered)
    spdlog::debug("scene '{}' registered again: unchanged", cfg.name);
  else if (r.scene == nullptr)
    spdlog::info("scene registration refused: {}", r.status.message());
  if (r.scene != nullptr) *response = describe_scene(*r.scene);
  reactor->Finish(to_grpc_status(r));
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::GetServerInfo(grpc::CallbackServerContext* context,
                                                         const v1::GetServerInfoRequest* /*request*/,
                                                         v1::GetServerInfoResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  *response = server_info_;
  describe_scheduling(context_.scheduler(), context_.backends(), context_.models(), *response);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DynamicsService::Calibrate(grpc::CallbackServerContext* context,
                                                     const v1::CalibrateRequest* /*request*/,
                                                     v1::CalibrateResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!admit_call(context, reactor)) return reactor;
  std::unique_lock lock(calibrating_, std::try_to_lock);
  if (!lock.owns_lock()) {
    reactor->Finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "a calibration is running already"));
    return reactor;
  }
  spdlog::info("calibration requested");
  scheduler_.calibrate(true, [&](const std::string& line) {
    spdlog::info("{}", line);
    response->add_log(line);
  });
  *response->mutable_info() = server_info_;
  describe_scheduling(context_.scheduler(), context_.backends(), context_.models(), *response->mutable_info());
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

}  // namespace rbdgrad::server
