#include "batch_plan.hpp"

#include <cstddef>
#include <cstdio>
#include <string>

namespace rbdgrad::plugin {

namespace {
std::string hex(std::uint32_t flags) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%x", flags);
  return text;
}
}  // namespace

ExecutionPlan BatchPlan::execution_plan(const ExecutionPlan& from_request) const {
  ExecutionPlan plan = from_request;
  plan.minv_supplied = minv_supplied;
  if (fext_bodies.empty() || from_request.external_forces == ExternalForces::kNone) {
    plan.external_forces = ExternalForces::kNone;
  } else {
    // the bodies are checked against the model's count (plan_from_desc); a model past the mask's
    // capacity reads every body, whose forces the host has zeroed where the plan has none
    BodyMask mask;
    bool fits = true;
    for (const std::uint32_t body : fext_bodies) fits = fits && mask.set(static_cast<int>(body));
    plan.external_forces = fits ? ExternalForces::kSomeBodies : ExternalForces::kAllBodies;
    plan.fext_bodies = fits ? mask : BodyMask{};
  }
  return plan;
}

bool model_desc_has_plan(const rbdgrad_model_desc& d) {
  return d.struct_size >= offsetof(rbdgrad_model_desc, plan) + sizeof(d.plan);
}

Status plan_from_desc(const rbdgrad_model_desc& d, std::uint32_t supported, std::optional<BatchPlan>& out) {
  out.reset();
  if (!model_desc_has_plan(d) || d.plan == nullptr) return Status::ok();
  const rbdgrad_plan& p = *d.plan;
  if (p.struct_size < sizeof(rbdgrad_plan))
    return invalid_argument("model_desc.plan.struct_size is " + std::to_string(p.struct_size) + ", expected at least " +
                            std::to_string(sizeof(rbdgrad_plan)));
  if (p.outputs == 0) return invalid_argument("model_desc.plan.outputs is 0: a plan computes at least one output");
  if ((p.outputs & ~supported) != 0)
    return Status(StatusCode::kUnimplemented,
                  "model_desc.plan.outputs has flags " + hex(p.outputs & ~supported) +
                      " that this backend does not compute");
  if (p.minv_supplied > 1)
    return invalid_argument("model_desc.plan.minv_supplied is " + std::to_string(p.minv_supplied) + ": must be 0 or 1");
  if (p.fext_body_count > d.nv)
    return invalid_argument("model_desc.plan.fext_body_count is " + std::to_string(p.fext_body_count) +
                            ", more than the model's " + std::to_string(d.nv) + " bodies");
  if (p.fext_body_count > 0 && p.fext_bodies == nullptr)
    return invalid_argument("model_desc.plan.fext_bodies is NULL with fext_body_count " +
                            std::to_string(p.fext_body_count));
  BatchPlan plan;
  plan.outputs = p.outputs;
  plan.minv_supplied = p.minv_supplied == 1;
  for (std::uint32_t k = 0; k < p.fext_body_count; ++k) {
    const std::uint32_t body = p.fext_bodies[k];
    const std::string field = "model_desc.plan.fext_bodies[" + std::to_string(k) + "] is " + std::to_string(body);
    if (body >= d.nv) return invalid_argument(field + ", outside the model's " + std::to_string(d.nv) + " bodies");
    if (k > 0 && body <= p.fext_bodies[k - 1])
      return invalid_argument(field + ", not above the one before it (the bodies are ascending, each once)");
    plan.fext_bodies.push_back(body);
  }
  out = std::move(plan);
  return Status::ok();
}

Status check_batch_plan(const rbdgrad_batch& batch, const BatchPlan& plan) {
  if ((batch.outputs & ~plan.outputs) != 0)
    return invalid_argument("batch.outputs asks for flags " + hex(batch.outputs & ~plan.outputs) +
                            " outside the instance's plan");
  if ((batch.minv != nullptr) != plan.minv_supplied)
    return invalid_argument(plan.minv_supplied ? "batch.minv is NULL, but the instance's plan has M^-1 supplied"
                                               : "batch.minv is set, but the instance's plan computes M^-1");
  // (a batch without fext has no forces, which any plan allows)
  if (batch.fext != nullptr && plan.fext_bodies.empty())
    return invalid_argument("batch.fext is set, but the instance's plan has no external forces");
  return Status::ok();
}

}  // namespace rbdgrad::plugin
