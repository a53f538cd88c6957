// The linearization of a whole trajectory from rbdgradd: one batched Compute request per
// iteration (N = horizon states, input τ; outputs q̈, M⁻¹, ∂q̈/∂q, ∂q̈/∂q̇) on one backend in one
// precision, turned into the Euler step's A and B. Also measures, outside the timed call, how far
// the backend's outputs are from the core library's f64 at the same states.
#pragma once

#include <string>
#include <vector>

#include "arm_plant.hpp"
#include "ilqr.hpp"
#include "linearizer_stats.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::trajopt {

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
