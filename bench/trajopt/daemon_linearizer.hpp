// The linearization of a whole trajectory from rbdgradd: one batched Compute request per
// iteration (N = horizon states, input τ; outputs q̈, M⁻¹, ∂q̈/∂q, ∂q̈/∂q̇) on one backend in one
// precision, turned into the Euler step's A and B. Also measures, outside the timed call, how far
// the backend's outputs are from the core library's f64 at the same states.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "arm_plant.hpp"
#include "ilqr.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::trajopt {

struct LinearizerStats {
  int calls = 0;
  double round_trip_s = 0;       // client: the Compute calls, end to end
  double server_compute_s = 0;   // server: in the backend
  std::uint64_t states = 0;
  std::uint64_t fallback_states = 0;  // fixed point: states the server computed again in floating point
  std::string backend_mode;      // "" or "csim", as the responses say
  Precision precision_used = Precision::kAuto;
  // worst relative Frobenius error per state against the core library's f64, over every state sent
  double max_grad_error = 0;     // of [∂q̈/∂q ∂q̈/∂q̇]
  double max_minv_error = 0;     // of M⁻¹
  double check_s = 0;            // time spent on that comparison (not part of the optimization)
};

class DaemonLinearizer {
 public:
  /// `reference` computes the f64 derivatives for the error measurement (its own workspace: not the
  /// plant's, which the rollouts use).
  DaemonLinearizer(const Client& client, std::string model, Backend backend, Precision precision, ArmPlant& reference);

  /// Fills `out` for every step of `t`; returns "" or the problem (the call's status, or a
  /// response from another backend or precision than asked).
  std::string operator()(const Trajectory& t, Linearization& out);

  const LinearizerStats& stats() const { return stats_; }

 private:
  const Client& client_;
  std::string model_;
  Backend backend_;
  Precision precision_;
  ArmPlant& reference_;
  std::vector<double> q_, qd_, tau_;
  ComputeResult result_;
  LinearizerStats stats_;
};

}  // namespace rbdgrad::trajopt
