// Sends the states of `rbdgrad compute` to the server in as few requests as its limits allow,
// and keeps every result where the states can find it (no copy of the outputs).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "compute_states.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::cli {

// What every request asks for.
struct BatchPlan {
  std::string model;
  std::string scene;  // a scene instead of the model ("" = none)
  Precision precision = Precision::kAuto;
  Backend backend = Backend::kAuto;
  std::uint32_t outputs = 0;  // Output bits
  ScalarType output_type = ScalarType::kF64;
  int nv = 0;
  std::uint32_t max_states_per_request = 0;  // the server's limits (0 = none)
  std::uint64_t max_message_bytes = 0;
};

struct ComputedStates {
  // Where a state's outputs are: state k of results[result]; or its error (result -1).
  struct Slot {
    int result = -1;
    std::uint32_t k = 0;
    std::string error;
  };
  std::vector<ComputeResult> results;  // one per successful request
  std::vector<Slot> slots;             // one per input state, in the same order
  std::size_t requests = 0;            // sent, including failed ones
  ComputeTimings sum;                  // over the successful requests
};

/// The largest number of states per request under the server's limits (at least 1).
std::uint32_t states_per_request(const BatchPlan& plan);

/// Sends `states` (those without an error; the others keep theirs in their slot) in requests of
/// consecutive states with the same input kind. A request refused
/// for a per-state reason (INVALID_ARGUMENT, OUT_OF_RANGE, FAILED_PRECONDITION: a bad value, an
/// overflow, a singular M) is resent one state per request, so that only the failing states get
/// an error: "state 5: OUT_OF_RANGE: <the server's message>".
/// \return ok, or the status that stops the whole run (no server, unknown model, deadline, ...).
RpcStatus compute_in_batches(const Client& client, const BatchPlan& plan, const std::vector<InputState>& states,
                             ComputedStates& out);

}  // namespace rbdgrad::cli
