// The host's entry to the warp kernel (warp_kernel.cu, device/warp_fused_state.hpp): a segment of
// 8 or 16 lanes of a warp per state, lane i holding joint i, computing in f64. It takes the block
// kernel's gradient requests for models of up to kMaxWarpNv joints, with f64 or (computed in f64)
// f32 batches.
#pragma once

#include <cuda_runtime_api.h>

#include "block_launch.hpp"
#include "device/warp_kernel_entry.hpp"

namespace rbdgrad::cuda {

/// Batches whose outputs take at least this many bytes write their first ones (qdd, d qdd/d qd)
/// before computing d tau/d q, so that the writes overlap it (KernelOptions::
/// warp_early_outputs_min_bytes); smaller ones write everything at the end, which costs a state
/// less. On the H200 (docs/benchmarks/cuda.md, run 46) iiwa14 gained from 196 KiB of outputs (f64
/// at 256 states, f32 at 512) and mostly lost or broke even at 98 KiB and less (f32 at 256
/// states went both ways in runs 46 and 47).
inline constexpr std::uint64_t kDefaultWarpEarlyOutputsMinBytes = 160 * 1024;

/// The block for `bytes` of inputs (<= kWarpInlineInputBytes), at least `min_block` bytes.
constexpr std::size_t warp_inline_block_bytes(std::size_t bytes, std::size_t min_block = 0) {
  const std::size_t need = bytes > min_block ? bytes : min_block;
  return need <= 2048 ? 2048 : need <= 4096 ? 4096 : kWarpInlineInputBytes;
}

/// The warp kernel's entry points (device/warp_kernel_entry.hpp) for a batch: the first outputs
/// written late or early, or the inputs in the parameters in a block of 2, 4 or 8 KiB.
enum class WarpEntry { kLate, kEarly, kInline2048, kInline4096, kInline8192 };
inline constexpr int kWarpEntries = 5;

/// One robot's entry points (SpecializedWarpKernel): by the batch's scalars and WarpEntry, each
/// null where the generic kernel's is taken.
struct WarpKernelTable {
  const void* f64[kWarpEntries] = {};
  const void* f32[kWarpEntries] = {};
};

/// The launch launch_warp_fused would make (for a CUDA Graph's kernel node, kernel_graphs.hpp);
/// the kernel's arguments are the model view and the batch pointers, in that order, then with
/// inline_block (a warp_inline_block_bytes size; 0: none) the first inline_block bytes of a
/// WarpInlineInputs, whose inputs replace the batch's q, qd and u.
/// `robot`: the entry points compiled for the model, where not null.
template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch,
                               std::uint64_t early_outputs_min_bytes = kDefaultWarpEarlyOutputsMinBytes,
                               std::size_t inline_block = 0, const WarpKernelTable* robot = nullptr);

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
/// Measurement builds: the SM clock of state 0's segment at the kernel's entry and at the end of
/// each stage of the last launch (count <= WarpLanes<8>::kMaxStageClocks + 1).
cudaError_t read_warp_stage_clocks(long long* out, int count);
#endif

/// Enqueues the kernel on `stream` for every state of `batch` (warp_kernel_supports(batch, nv)),
/// its inputs from the first inline_block bytes of inline_inputs where given (no external forces
/// or M^-1 then); `robot` as in warp_fused_launch.
template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch,
                              std::uint64_t early_outputs_min_bytes, const WarpInlineInputs* inline_inputs,
                              std::size_t inline_block, cudaStream_t stream, const WarpKernelTable* robot = nullptr);

}  // namespace rbdgrad::cuda
