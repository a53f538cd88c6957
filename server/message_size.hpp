// limits.max_message_bytes when the configuration leaves it at 0: derived from
// limits.max_states_per_request and the largest model served, so that every request the daemon
// accepts (and its response) fits, and nothing much larger does.
#pragma once

#include <cstdint>
#include <string>

#include "model_registry.hpp"

namespace rbdgrad::server {

/// Bytes of anything in a message besides the per-state arrays: ids, timings, failovers, parts,
/// the tensors' framing.
inline constexpr std::uint64_t kMessageMarginBytes = std::uint64_t{1} << 20;

/// The larger of the largest ComputeRequest (q, qd, u, a supplied M^-1 and external forces on
/// every body, in f64) and the largest ComputeResponse (all eight outputs in f64, every state
/// listed as a fixed-point fallback) of `states` states of a model of `nv` joints, plus
/// kMessageMarginBytes.
std::uint64_t largest_compute_message_bytes(std::uint64_t states, std::uint64_t nv);

/// largest_compute_message_bytes over every model and scene of `models`, at most 2^31-1 (gRPC's
/// limit is an int). `how` says how it was found, for the start-up log.
std::int64_t derived_max_message_bytes(const ModelRegistry& models, std::int64_t max_states_per_request,
                                       std::string& how);

}  // namespace rbdgrad::server
