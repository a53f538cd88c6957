// One model on the FPGA backend: the robot block loaded into the kernel once, and compute() that
// streams a batch through the kernel in chunks, double-buffered (chunk k+1 is packed and started
// while chunk k computes, as paper 000 overlaps transfers with computation).
//
// The host's share of each state, as the paper's FPGA design divides the work: sin and cos of q,
// M^-1 (the core library in double, unless the caller supplies it), and the conversions. Batches
// are Q16.16, the kernel's own format: the words go to the kernel as they come.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/batch_plan.hpp"
#include "host/kernel_runner.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::fpga {

// What the kernel computes: the forward-dynamics gradient; M^-1 comes from the host.
inline constexpr std::uint32_t kFpgaOutputs =
    RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;

/// The kernel's column datapaths (kColumnsDq, kColumnsDqd of kernel/gradient_kernel.hpp) that the
/// rbdgrad_output flags `outputs` need: a batch's set its mode word, a plan's its latency estimate.
unsigned kernel_columns(std::uint32_t outputs);

class FpgaInstance {
 public:
  /// \param model a validated model of at most kDeviceMaxNv joints whose constants fit Q16.16.
  /// \param runner the kernel, with areas for chunk_states states of this model.
  /// \param plan what every batch computes (a scene's, checked by plan_from_desc), or none.
  /// Errors: unimplemented when the model does not fit the kernel, or the plan has external
  /// forces; the runner's from set_robot.
  static Status create(const Model& model, std::unique_ptr<KernelRunner> runner, std::size_t chunk_states,
                       std::unique_ptr<FpgaInstance>& out, std::optional<plugin::BatchPlan> plan = std::nullopt);

  /// Computes a Q16.16 batch of the outputs in kFpgaOutputs (no external forces). Every state is
  /// attempted; a state that leaves the Q16.16 range, at the host (an input or M^-1 that does not
  /// fit) or in the kernel (its status word), gets RBDGRAD_ERROR_OUT_OF_RANGE in state_status, a
  /// singular M NUMERICAL; the error names the first failed state. Not reentrant.
  Status compute(const rbdgrad_batch* batch);

  /// The column datapaths its batches run at most: the plan's (a scene's), or both without a plan
  /// (each batch's outputs then choose). What estimate_latency predicts.
  unsigned columns() const;

  const KernelRunner& runner() const { return *runner_; }
  std::size_t chunk_states() const { return chunk_states_; }

 private:
  // a failed state, remembered for the returned error
  struct Failures {
    std::size_t count = 0;
    std::size_t first = 0;
    Status status;
    void add(std::size_t k, Status s);
  };

  FpgaInstance(const Model& model, std::unique_ptr<KernelRunner> runner, std::size_t chunk_states,
               std::optional<plugin::BatchPlan> plan);
  // packs states [begin, begin + count) into `slot`, writing the M^-1 output on the way; states
  // the host cannot pack are marked in refused_[slot]
  void pack_chunk(const rbdgrad_batch& batch, int slot, std::size_t begin, std::size_t count, Failures& failures);
  // the slot's results into the batch
  void unpack_chunk(const rbdgrad_batch& batch, int slot, std::size_t begin, std::size_t count, Failures& failures);

  Model model_;
  std::optional<plugin::BatchPlan> plan_;  // a scene's: batches must follow it
  WorkspaceTpl<double> ws_;  // M^-1 on the host
  std::unique_ptr<KernelRunner> runner_;
  std::size_t chunk_states_;
  std::vector<std::uint8_t> refused_[KernelRunner::kSlots];  // (chunk_states) per state of the slot
  std::vector<double> q_, qd_, u_, minv_;                    // one state in double (nv, nv x nv)
  std::string error_;                                        // pack_state's reason
};

}  // namespace rbdgrad::fpga
