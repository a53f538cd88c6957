// The host's entry to the warp kernel (warp_kernel.cu, device/warp_fused_state.hpp): a segment of
// 8 or 16 lanes of a warp per state, lane i holding joint i, computing in f64. It takes the block
// kernel's gradient requests for models of up to kMaxWarpNv joints, with f64 or (computed in f64)
// f32 batches.
#pragma once

#include <cuda_runtime_api.h>

#include "block_launch.hpp"
#include "device/warp_fused_state.hpp"

namespace rbdgrad::cuda {

/// Threads per block: 64 (two warps) holds 8 or 4 states in at most 34 KiB of shared memory,
/// within the default limit, and lets a small batch spread over the most SMs.
inline constexpr int kWarpKernelThreads = 64;

/// Batches whose outputs take at least this many bytes write their first ones (qdd, d qdd/d qd)
/// before computing d tau/d q, so that the writes overlap it (KernelOptions::
/// warp_early_outputs_min_bytes); smaller ones write everything at the end, which costs a state
/// less. On the H200 (docs/benchmarks/cuda.md, run 46) iiwa14 gained from 196 KiB of outputs (f64
/// at 256 states, f32 at 512) and mostly lost or broke even at 98 KiB and less (f32 at 256
/// states went both ways in runs 46 and 47).
inline constexpr std::uint64_t kDefaultWarpEarlyOutputsMinBytes = 160 * 1024;

/// A small batch's inputs carried in the kernel's parameters (q, qd, then u, each n x nv in the
/// batch's scalars): the launch brings them to the SMs, which then read no host memory over PCIe
/// before they can start. 8 KiB hold 48 states of iiwa14 in f64, 97 in f32.
inline constexpr std::size_t kWarpInlineInputBytes = 8192;
struct WarpInlineInputs {
  alignas(16) unsigned char bytes[kWarpInlineInputBytes];
};

/// The launch launch_warp_fused would make (for a CUDA Graph's kernel node, kernel_graphs.hpp);
/// the kernel's arguments are the model view and the batch pointers, in that order, then with
/// inline_inputs the WarpInlineInputs (whose inputs replace the batch's q, qd and u).
template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch,
                               std::uint64_t early_outputs_min_bytes = kDefaultWarpEarlyOutputsMinBytes,
                               bool inline_inputs = false);

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
/// Measurement builds: the SM clock of state 0's segment at the kernel's entry and at the end of
/// each stage of the last launch (count <= WarpLanes<8>::kMaxStageClocks + 1).
cudaError_t read_warp_stage_clocks(long long* out, int count);
#endif

/// Enqueues the kernel on `stream` for every state of `batch` (warp_kernel_supports(batch, nv)),
/// its inputs from inline_inputs where given (no external forces or M^-1 then).
template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch,
                              std::uint64_t early_outputs_min_bytes, const WarpInlineInputs* inline_inputs,
                              cudaStream_t stream);

}  // namespace rbdgrad::cuda
