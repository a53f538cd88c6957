// ListModels / GetModel / GetServerInfo responses -> ServedModel, ModelDescription, ServerInfo.
#include "info_decoding.hpp"

#include "request_encoding.hpp"

namespace rbdgrad::detail {

std::vector<ServedModel> decode(const v1::ListModelsResponse& r) {
  std::vector<ServedModel> out;
  out.reserve(static_cast<std::size_t>(r.models_size()));
  for (const v1::ModelSummary& m : r.models()) out.push_back({m.name(), static_cast<int>(m.nv()), m.source()});
  return out;
}

ModelDescription decode(const v1::GetModelResponse& r) {
  ModelDescription d;
  d.name = r.name();
  d.nv = static_cast<int>(r.nv());
  d.joints.reserve(static_cast<std::size_t>(r.joints_size()));
  for (const v1::Joint& j : r.joints())
    d.joints.push_back({j.name(), j.type(), j.parent(), j.parent_link(), j.child_link(), j.lower_limit(),
                        j.upper_limit(), j.effort_limit(), j.velocity_limit()});
  // a server that sends no gravity leaves zeros rather than a guess
  for (int i = 0; i < 3 && i < r.gravity_size(); ++i) d.gravity(i) = r.gravity(i);
  d.summary = r.summary();
  return d;
}

SceneDescription decode(const v1::Scene& r) {
  SceneDescription d;
  d.name = r.name();
  d.model = r.model();
  d.nv = static_cast<int>(r.nv());
  for (const v1::Joint& j : r.joints())
    d.joints.push_back({j.name(), j.type(), j.parent(), j.parent_link(), j.child_link(), j.lower_limit(),
                        j.upper_limit(), j.effort_limit(), j.velocity_limit()});
  for (int i = 0; i < r.locked_joints_size() && i < r.locked_values_size(); ++i)
    d.locked_joints.emplace_back(r.locked_joints(i), r.locked_values(i));
  d.gravity = r.gravity();
  d.force_links.assign(r.force_links().begin(), r.force_links().end());
  for (Output o : kEveryOutput)
    for (int p : r.outputs())
      if (p == output_to_proto(o)) d.outputs |= static_cast<std::uint32_t>(o);
  d.minv_supplied = r.minv_supplied();
  return d;
}

ServerInfo decode(const v1::GetServerInfoResponse& r) {
  ServerInfo info;
  info.version = r.version();
  for (const v1::BackendInfo& b : r.backends()) {
    BackendStatus s;
    s.backend = from_proto(b.backend());
    s.name = b.name();
    s.ready = b.ready();
    s.reason = b.reason();
    for (int p : b.precisions()) s.precisions.push_back(from_proto(static_cast<v1::Precision>(p)));
    s.max_batch = b.max_batch();
    s.mode = b.mode();
    s.device = b.device();
    s.detail = b.detail();
    for (const v1::LatencyModelInfo& m : b.latency_models()) {
      LatencyModelStatus l;
      l.model = m.model();
      l.precision = from_proto(m.precision());
      l.source = m.source();
      l.fixed_us = m.fixed_us();
      l.per_state_us = m.per_state_us();
      l.n.assign(m.n().begin(), m.n().end());
      l.us.assign(m.us().begin(), m.us().end());
      s.latency_models.push_back(std::move(l));
    }
    for (const v1::QueueInfo& q : b.queues()) s.queues.push_back({q.model(), q.queued(), q.running(), q.pending_us()});
    info.backends.push_back(std::move(s));
  }
  info.max_states_per_request = r.max_states_per_request();
  info.max_message_bytes = r.max_message_bytes();
  info.max_concurrent_requests = r.max_concurrent_requests();
  info.scheduler_policy = r.scheduler_policy();
  for (const v1::RoutingInfo& ri : r.routing()) {
    RoutingStatus routing;
    routing.model = ri.model();
    for (const v1::RoutingInfo::Crossover& c : ri.crossovers()) routing.crossovers.emplace_back(c.from_n(), c.backend_name());
    routing.small_n = ri.small_n();
    routing.large_n = ri.large_n();
    info.routing.push_back(std::move(routing));
  }
  return info;
}

}  // namespace rbdgrad::detail
