// The plan of the plugin ABI (rbdgrad_plan, 1.3): what every batch of one instance computes, as a
// scene fixes it. Read and checked once when the instance is created; each batch is then checked
// against it (a host must send only batches that follow it).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::plugin {

struct BatchPlan {
  std::uint32_t outputs = 0;               // rbdgrad_output flags a batch may ask for
  bool minv_supplied = false;              // every batch brings M^-1
  std::vector<std::uint32_t> fext_bodies;  // ascending; empty = no external forces

  /// Whether the plan's outputs include `flag`.
  bool wants(std::uint32_t flag) const { return (outputs & flag) != 0; }
  /// The core's plan of a batch that follows this plan, from the one plan_request made of the batch
  /// (its columns, gravity): forces on the plan's bodies only (none when the batch has no fext),
  /// M^-1 as the plan says.
  ExecutionPlan execution_plan(const ExecutionPlan& from_request) const;

  friend bool operator==(const BatchPlan&, const BatchPlan&) = default;
};

/// Whether a description of struct_size bytes has room for the 1.3 field plan.
bool model_desc_has_plan(const rbdgrad_model_desc& d);

/// The plan of `d` (none when the host's description predates it or its plan is NULL), checked
/// against the model of d.nv bodies and the outputs the backend computes (`supported`): invalid_argument
/// "model_desc.plan.fext_bodies[2] is 9, outside the model's 7 bodies" and the like.
Status plan_from_desc(const rbdgrad_model_desc& d, std::uint32_t supported, std::optional<BatchPlan>& out);

/// invalid_argument when `batch` does not follow `plan`: it asks for an output the plan has not,
/// brings M^-1 where the plan says otherwise, or fext where the plan has no forces (the message
/// names the field).
Status check_batch_plan(const rbdgrad_batch& batch, const BatchPlan& plan);

}  // namespace rbdgrad::plugin
