// Batching of `rbdgrad compute`: chunks under the server's limits, per-state errors isolated.
#include "compute_batches.hpp"

#include <algorithm>
#include <bit>
#include <span>

namespace rbdgrad::cli {

namespace {

bool is_per_state_error(RpcCode code) {
  return code == RpcCode::kInvalidArgument || code == RpcCode::kOutOfRange || code == RpcCode::kFailedPrecondition;
}

// One request for the states `which`: inputs gathered into contiguous arrays.
class BatchRequest {
 public:
  BatchRequest(const BatchPlan& plan, const std::vector<InputState>& states, std::span<const std::size_t> which,
               std::size_t serial) {
    for (std::size_t s : which) {
      q_.insert(q_.end(), states[s].q.begin(), states[s].q.end());
      qd_.insert(qd_.end(), states[s].qd.begin(), states[s].qd.end());
      u_.insert(u_.end(), states[s].u.begin(), states[s].u.end());
    }
    req_.model = plan.model;
    req_.scene = plan.scene;
    req_.num_states = static_cast<std::uint32_t>(which.size());
    req_.precision = plan.precision;
    req_.input = states[which.front()].input;
    req_.outputs = plan.outputs;
    req_.q = q_;
    req_.qd = qd_;
    req_.u = u_;
    req_.backend = plan.backend;
    req_.output_type = plan.output_type;
    req_.request_id = "rbdgrad-compute-" + std::to_string(serial);
  }
  const ComputeRequest& get() const { return req_; }

 private:
  std::vector<double> q_, qd_, u_;
  ComputeRequest req_;
};

}  // namespace

std::uint32_t states_per_request(const BatchPlan& plan) {
  const auto nv = static_cast<std::uint64_t>(plan.nv);
  const auto vectors = static_cast<std::uint64_t>(std::popcount(plan.outputs & (mask(Output::kQdd) | mask(Output::kTau))));
  const auto matrices = static_cast<std::uint64_t>(std::popcount(plan.outputs)) - vectors;
  // the response is the larger message; a fifth of the limit is left for framing and headroom
  const std::uint64_t bytes_per_state = 8 * std::max(3 * nv, vectors * nv + matrices * nv * nv) + 1;
  std::uint64_t n = plan.max_message_bytes > 0 ? plan.max_message_bytes * 4 / 5 / bytes_per_state : UINT32_MAX;
  if (plan.max_states_per_request > 0) n = std::min<std::uint64_t>(n, plan.max_states_per_request);
  return static_cast<std::uint32_t>(std::clamp<std::uint64_t>(n, 1, UINT32_MAX));
}

RpcStatus compute_in_batches(const Client& client, const BatchPlan& plan, const std::vector<InputState>& states,
                             ComputedStates& out) {
  out.slots.assign(states.size(), {});
  const std::size_t limit = states_per_request(plan);
  // sends the states `which` in one request; on success their slots point into the result
  auto send = [&](std::span<const std::size_t> which) {
    const BatchRequest request(plan, states, which, out.requests++);
    ComputeResult result;
    RpcStatus st = client.compute(request.get(), result);
    if (!st) return st;
    out.sum.queue_us += result.timings().queue_us;
    out.sum.compute_us += result.timings().compute_us;
    out.sum.total_us += result.timings().total_us;
    out.sum.round_trip_us += result.timings().round_trip_us;
    const int index = static_cast<int>(out.results.size());
    for (std::size_t k = 0; k < which.size(); ++k) out.slots[which[k]] = {index, static_cast<std::uint32_t>(k), ""};
    out.results.push_back(std::move(result));
    return st;
  };
  std::vector<std::size_t> chunk;
  std::size_t next = 0;
  while (next < states.size()) {
    // the next run of sendable states with one input kind, at most `limit` long
    chunk.clear();
    for (; next < states.size() && chunk.size() < limit; ++next) {
      if (!states[next].error.empty()) {
        out.slots[next].error = states[next].error;
        continue;
      }
      if (!chunk.empty() && states[next].input != states[chunk.front()].input) break;
      chunk.push_back(next);
    }
    if (chunk.empty()) continue;
    const RpcStatus st = send(chunk);
    if (st) continue;
    if (!is_per_state_error(st.code())) return st;
    // find the failing states: one request each
    for (std::size_t s : chunk) {
      const RpcStatus one = chunk.size() == 1 ? st : send(std::span<const std::size_t>(&s, 1));
      if (!one && !is_per_state_error(one.code())) return one;
      if (!one) out.slots[s].error = "state " + std::to_string(states[s].index) + ": " + one.to_string();
    }
  }
  return RpcStatus::ok();
}

}  // namespace rbdgrad::cli
