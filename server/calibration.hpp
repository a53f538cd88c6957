// Calibration: a backend's latency model for one model and precision, from timing its instances
// on batches of random states (the gradient request of MPC: q, qd, tau in; qdd, d qdd/d q and
// d qdd/d qd out) over a sweep of N, or from the plugin's own model where it has one (the FPGA's
// cycle count, API 1.2 estimate_latency). The fingerprints say when a saved model still holds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "backend_pool.hpp"
#include "instance_pool.hpp"
#include "latency_model.hpp"
#include "model_registry.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

struct CalibrationOptions {
  // batch sizes timed, ascending; a size above the plugin's max_batch is skipped
  std::vector<std::uint64_t> sizes = {1, 4, 16, 64, 256, 1024, 4096};
  // calls per size; the median counts
  int repetitions = 7;
  // no larger size is timed once a call takes this long: the model grows at its last rate beyond
  double max_call_us = 50000;
};

/// The hardware and software a backend's times depend on: its plugin (name, version), its device
/// (describe_instance), its options, and the host's CPU model and core count.
std::string backend_fingerprint(const BackendState& backend);
/// A hash of everything a backend's work on the model depends on (the ABI description's arrays).
std::string model_fingerprint(const ServedModel& model);

/// Times `pool` (a pool of `model` on one backend) in `precision` over options.sizes: for each
/// size, a warm-up call, then `repetitions` calls, the median. Blocks until done; the pool must be
/// otherwise idle for the figures to mean anything. Errors: the backend's (naming the size).
Status measure_latency(InstancePool& pool, const ServedModel& model, std::uint32_t precision,
                       const CalibrationOptions& options, LatencyModel& out);

/// The plugin's own model (estimate_latency) at options.sizes. Errors: unimplemented when it has
/// none (then measure), or the plugin's.
Status estimated_latency(const PluginInstance& instance, std::uint32_t precision, const CalibrationOptions& options,
                         LatencyModel& out);

}  // namespace rbdgrad::server
