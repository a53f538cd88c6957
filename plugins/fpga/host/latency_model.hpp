// The FPGA backend's latency model: cycles per gradient for a robot, derived from the structure of
// the kernel as it is written (kernel/gradient_kernel.hpp, kernel/gradient_top.cpp), and the time
// of a batch of N states at a given clock, AXI and host transfers included. The scheduler uses it
// as the FPGA's cost model until measurements on hardware calibrate it.
//
// How the kernel's code becomes cycles (the derivation of each figure is in latency_model.cpp):
// - operations are trees of multipliers and adders: a 6-term dot product is one multiplier level
//   and ceil(log2 6) = 3 adder levels, and the sparsity of X and S is written out in the code, so
//   a joint transform is a cross product, a subtraction and a 3x3 rotation (2 multiplier and 4
//   adder levels);
// - the loops over links are serial (each link needs its parent's values, and the code has no
//   overlap of siblings), and within a link the body's values (v, a, f) come before the columns;
// - the loops over the columns of dc/du carry UNROLL factor = 2 and run over the columns the mode
//   selects (ColumnRange: 2 nv for both derivatives, nv for one, none for qdd alone): ceil(k / U)
//   passes for k columns, one after another, each as deep as one column's datapath (UNROLL stops
//   HLS from pipelining them); the column datapaths are the same whichever range runs;
// - joint_transforms carries PIPELINE II = 1; the loops without a pragma (the dot products with
//   M^-1, their rows, the element-wise loops over joints) run one iteration at a time unless
//   KernelTiming::pipeline_unmarked_loops says otherwise;
// - the top function reads a state, computes it and writes it back, one state after another (no
//   DATAFLOW): a batch costs N times (AXI in + compute + AXI out), plus the robot's words once.
// Assumed, not in the code yet: the working arrays are partitioned so that each datapath reads and
// writes its 6-vectors in one access (the kernel has no ARRAY_PARTITION pragma yet; without one
// the passes are bound by the BRAM ports and HLS will report them longer).
//
// The idealised figure (LatencyEstimate::ideal_cycles_per_gradient) is the paper's design
// (000, section IV-C) on the same operators: every column its own datapath, the body's v, a, f
// overlapped with the columns, and siblings in parallel (the sweeps run over the tree's depth).
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernel/gradient_kernel.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::fpga {

/// UNROLL factor of the loops over the columns of dc/du in kernel/gradient_kernel.hpp (the
/// forward and backward sweeps and the -M^-1 dc/du product carry the same one).
inline constexpr int kKernelColumnUnroll = 2;
/// PIPELINE II of joint_transforms' loop over joints in kernel/gradient_kernel.hpp.
inline constexpr int kKernelJointTransformII = 1;

/// What the kernel's input u holds (the top function's mode bit kModeTauInput).
enum class InputKind {
  kQdd,  // u = qdd: copied
  kTau,  // u = tau: qdd = M^-1 (tau - c), with c from a first RNEA pass (the bias pass: no columns)
};

/// The column datapaths of the gradient that run (kernel/gradient_kernel.hpp): kColumnsDq for
/// dqdd/dq, kColumnsDqd for dqdd/dqd, both (the full gradient), or 0 (qdd alone). The top
/// function's mode bits kModeNoDq and kModeNoDqd leave the others out.
inline constexpr unsigned kAllColumns = kColumnsDq | kColumnsDqd;

/// The constants of the model. Defaults are for an Alveo-class card (U250/U280) at its default
/// kernel clock; every one of them is an assumption until a Vitis HLS synthesis report (the
/// operator latencies and loop structure) and runs on hardware (AXI, PCIe, host) calibrate it.
struct KernelTiming {
  // operator latencies in cycles at clock_mhz, for Q16.16 (ap_fixed<32, 16>) operands
  int multiplier_cycles = 3;    // a full 32x32 product from cascaded DSP48E2s, registered
  int adder_cycles = 1;         // one 32-bit add (also the wide accumulator's step: the dot's II)
  int memory_read_cycles = 1;   // on-chip BRAM read, output not registered
  int loop_iteration_overhead_cycles = 1;  // per iteration of a loop that is not pipelined (exit test, stores)

  // loop structure, as the kernel's pragmas say
  int column_unroll = kKernelColumnUnroll;           // columns of dc/du computed side by side
  int joint_transform_ii = kKernelJointTransformII;  // initiation interval of joint_transforms
  bool pipeline_unmarked_loops = false;  // true: the loops without a pragma pipelined at II 1 (adder_cycles
                                         // for an accumulation), as an added PIPELINE pragma would make them

  // AXI master ports (gmem0 in: robot words and states; gmem1 out)
  int axi_port_bits = 32;               // the DeviceWord pointers' width: the top's interleaved reads
                                        // are unlikely to be widened automatically
  double axi_burst_efficiency = 1.0;    // useful beats / cycles while a transfer streams, in (0, 1]
  int axi_latency_cycles = 64;          // per transfer (request to first beat, or last beat to response):
                                        // Vitis HLS's scheduling default for m_axi in the kernel flow

  double clock_mhz = 300.0;  // Alveo platforms' default kernel clock; paper 000's design ran at 55.6

  // host side, per batch
  double host_round_trip_us = 50.0;  // XRT launch, wait and the two buffer syncs: a placeholder
  double pcie_gbytes_per_s = 10.0;   // host <-> card buffer copies (PCIe Gen3 x16 is 15.75 GB/s raw)
};

/// Errors: invalid_argument naming the first field out of its range.
Status check_timing(const KernelTiming& timing);

/// Cycles of one gradient, by phase of fd_gradient in the order it runs them.
struct PhaseCycles {
  std::int64_t joint_transforms = 0;  // E and r of every joint from sin and cos of q
  std::int64_t qdd = 0;               // tau: a first RNEA pass (its sweeps without columns) and
                                      // M^-1 (tau - c); qdd: the copy of u
  std::int64_t forward_sweep = 0;     // Algorithm 5 lines 1-4: v, a, f and the columns dv, da, df
  std::int64_t backward_sweep = 0;    // lines 5-7: tau, dc/du and the forces into the parents
  std::int64_t minv_product = 0;      // dqdd/du = -M^-1 dc/du, the columns that run
  std::int64_t total() const {
    return joint_transforms + qdd + forward_sweep + backward_sweep + minv_product;
  }
};

struct LatencyEstimate {
  PhaseCycles phases;                          // one gradient, the kernel as written
  int column_passes = 0;                       // passes of each of the three column loops: ceil(k / U)
                                               // for the k columns that run
  std::int64_t cycles_per_gradient = 0;        // phases.total(): compute only
  std::int64_t ideal_cycles_per_gradient = 0;  // the same operators, paper 000's parallelism (see above)
  std::int64_t transfer_cycles_per_state = 0;  // AXI: the state's input words in, its output words out
  std::int64_t robot_transfer_cycles = 0;      // AXI: the robot's words, once per batch
  std::int64_t batch_cycles = 0;               // robot words + n_states x (transfer + compute)
  double gradient_us = 0;       // cycles_per_gradient at clock_mhz
  double ideal_gradient_us = 0;  // ideal_cycles_per_gradient at clock_mhz
  double kernel_us = 0;         // batch_cycles at clock_mhz: the kernel's run
  double host_transfer_us = 0;  // the batch's input and output buffers over PCIe
  double batch_us = 0;          // host_round_trip_us + host_transfer_us + kernel_us, one batch alone
                                // (no overlap with a neighbouring batch)
};

/// The latency of a batch of `n_states` gradients of `model` on the kernel.
/// \param[in] model  its nv and parent (dim nv) are read; nv in [1, kDeviceMaxNv].
/// \param[in] timing  checked as check_timing does.
/// \param[in] n_states  states in the batch, at least 1.
/// \param[in] input  what u holds; kTau runs a first RNEA pass.
/// \param[in] columns  the column datapaths that run (kAllColumns, kColumnsDq, kColumnsDqd or 0), as
///            the mode word sets them; the output words are the same (zeros for the others).
/// \param[out] out  filled only on success.
/// Errors: invalid_argument (a timing field, n_states 0, nv 0, a parent array that is not a
/// tree in depth-first order, or a column bit that is not one), failed_precondition (more joints
/// than the kernel takes).
Status estimate_latency(const Model& model, const KernelTiming& timing, std::size_t n_states, InputKind input,
                        unsigned columns, LatencyEstimate& out);

/// The full gradient: both column sets.
inline Status estimate_latency(const Model& model, const KernelTiming& timing, std::size_t n_states, InputKind input,
                               LatencyEstimate& out) {
  return estimate_latency(model, timing, n_states, input, kAllColumns, out);
}

}  // namespace rbdgrad::fpga
