// The host's entry to the warp kernel (warp_kernel.cu, device/warp_fused_state.hpp): a segment of
// 8 or 16 lanes of a warp per state, lane i holding joint i, computing in f64. It takes the block
// kernel's gradient requests for models of up to kMaxWarpNv joints, with f64 or (computed in f64)
// f32 batches.
#pragma once

#include <cuda_runtime_api.h>

#include "block_launch.hpp"
#include "device/warp_fused_state.hpp"

namespace rbdgrad::cuda {

/// Threads per block: 64 (two warps) holds 8 or 4 states in at most 25 KiB of shared memory,
/// within the default limit, and lets a small batch spread over the most SMs.
inline constexpr int kWarpKernelThreads = 64;

/// The launch launch_warp_fused would make (for a CUDA Graph's kernel node, kernel_graphs.hpp);
/// the kernel's arguments are the model view and the batch pointers, in that order.
template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch);

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
/// Measurement builds: the SM clock of state 0's segment at the kernel's entry and at the end of
/// each stage of the last launch (count <= WarpLanes<8>::kMaxStageClocks + 1).
cudaError_t read_warp_stage_clocks(long long* out, int count);
#endif

/// Enqueues the kernel on `stream` for every state of `batch` (warp_kernel_supports(batch, nv)).
template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch, cudaStream_t stream);

}  // namespace rbdgrad::cuda
