// The outcome of each trajectory-optimization run (one backend and precision through the daemon,
// or one fixed-point format of the FPGA kernel in-process) and its forms: CSV rows, a Markdown
// table with one plain sentence per run.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "reach_task.hpp"

namespace rbdgrad::trajopt {

struct RunRecord {
  std::string backend, precision;  // as asked: "cpu", "f64"; "fpga kernel", "Q12.20"
  std::string mode;                // "" or "csim"; "host" for the in-process kernel
  // kOverflowed: the kernel flagged a state, so the run stopped where it was (its numbers are of
  // that point) and did not reach the goal: the format's result, not the tool's failure
  enum class Outcome { kDone, kOverflowed, kFailed, kSkipped } outcome = Outcome::kDone;
  std::string reason;              // kFailed / kSkipped / kOverflowed: why; kDone: how the optimizer stopped
  int iterations = 0;
  int gradient_calls = 0;
  bool converged = false;
  double initial_cost = 0, final_cost = 0;
  double q_error = 0, qd_error = 0;  // ‖q_T − q_goal‖ rad, ‖q̇_T‖ rad/s
  double initial_q_error = 0;        // the same before optimizing (the arm held at q0)
  bool reached = false;
  double wall_s = 0;                 // the whole optimization, without the error measurement
  double gradient_s = 0;             // the Compute calls, client round trip; the kernel's runs
  double server_compute_s = 0;       // of which in the backend (all of it for the kernel)
  double max_grad_error = 0, max_minv_error = 0;  // relative to the core's f64, worst state
  std::uint64_t fallback_states = 0;    // daemon fixed point: computed again in f64
  std::uint64_t overflowed_states = 0;  // kernel: flagged in the call that stopped the run
  double max_tau_ratio = 0;          // max |τ_i| / effort limit_i over the trajectory
  double max_qd_ratio = 0;           // max |q̇_i| / velocity limit_i
  bool within_position_limits = true;
};

void write_csv(std::ostream& out, const std::vector<RunRecord>& runs);

/// A heading line on the task, the table, then one sentence per run on whether it reached the goal.
void write_markdown(std::ostream& out, const ReachTask& task, const std::string& context,
                    const std::vector<RunRecord>& runs);

}  // namespace rbdgrad::trajopt
