// The warp kernel's entry points (warp_fused_state.hpp: a segment of 8 or 16 lanes of a warp per
// state). One source for both builds of it: nvcc compiles it for any robot with Model =
// ModelView<double> (warp_kernel.cu), NVRTC for one robot with its sizes fixed
// (FixedSizeModelView, kernel_source.cpp).
#pragma once

#include "warp_fused_state.hpp"

namespace rbdgrad::cuda {

/// Threads per block: 64 (two warps) holds 8 or 4 states in 36 or 47.75 KiB of shared memory,
/// within the default limit, and lets a small batch spread over the most SMs.
inline constexpr int kWarpKernelThreads = 64;
/// A block's shared memory for segments of W lanes.
template <int W>
inline constexpr std::size_t kWarpBlockSharedBytes =
    static_cast<std::size_t>(WarpShared<W>::warp_scalars(WarpLanes<W>::kSegments)) * sizeof(double) *
    (kWarpKernelThreads / 32);
// no kernel attribute needed: the default allowance (and SpecializedWarpKernel's)
static_assert(kWarpBlockSharedBytes<8> <= 48 * 1024 && kWarpBlockSharedBytes<16> <= 48 * 1024,
              "the warp kernel's blocks fit the default 48 KiB of shared memory");

/// A small batch's inputs carried in the kernel's parameters (q, qd, then u, each n x nv in the
/// batch's scalars): the launch brings them to the SMs, which then read no host memory over PCIe
/// before they can start. The block is the smallest of 2, 4 or 8 KiB that holds them (the launch
/// carries all of it); 8 KiB hold 48 states of iiwa14 in f64, 97 in f32.
inline constexpr std::size_t kWarpInlineInputBytes = 8192;
template <std::size_t kBytes>
struct WarpInlineBlock {
  alignas(16) unsigned char bytes[kBytes];
};
using WarpInlineInputs = WarpInlineBlock<kWarpInlineInputBytes>;

#if defined(__CUDACC__)
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// Measurement builds only (never NVRTC's): state 0's clocks, [0] at the kernel's entry, then at
// the end of each stage (WarpLanes::stamp). Defined here: warp_kernel.cu is the one file nvcc
// compiles this part in.
__device__ long long g_warp_stage_clocks[WarpLanes<8>::kMaxStageClocks + 1];
#endif

// The states of `batch` on the block's warps; kEarlyOutputs: warp_evaluate_state's early_outputs.
template <int W, class Model, class IO, bool kEarlyOutputs>
__device__ __forceinline__ void warp_fused_block(const Model& model, const BatchPointers<IO>& batch) {
  extern __shared__ __align__(16) unsigned char shared[];  // 16: the rows' and products' paired accesses
  constexpr int kPerWarp = WarpLanes<W>::kSegments;
  const int tid = static_cast<int>(threadIdx.x);
  WarpLanes<W> g;
  g.lane = tid % W;
  g.segment = (tid % 32) / W;
  // the block's states one per segment, in order: a warp's states are consecutive
  const int slot = (tid / 32) * kPerWarp + g.segment;
  const std::uint64_t k =
      static_cast<std::uint64_t>(blockIdx.x) * (blockDim.x / W) + static_cast<std::uint64_t>(slot);
  const bool active = k < batch.n;
  g.first_state = k - static_cast<std::uint64_t>(g.segment);
  g.states_in_warp =
      g.first_state >= batch.n ? 0 : static_cast<int>(min(batch.n - g.first_state, std::uint64_t{kPerWarp}));
  g.shared_stride = WarpShared<W>::kScalars;
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (k == 0) {
    if (g.lane == 0) g_warp_stage_clocks[0] = clock64();
    g.clocks = g_warp_stage_clocks + 1;
  }
#endif
  double* sh = reinterpret_cast<double*>(shared) + (tid / 32) * WarpShared<W>::warp_scalars(kPerWarp) +
               g.segment * WarpShared<W>::kScalars;
  warp_evaluate_state<W, double, IO, block_stages::kPerBatch>(model, sh, batch, active ? k : batch.n - 1, active,
                                                               kEarlyOutputs, g);
}

// Model: ModelView<double>, or a FixedSizeModelView<double, ...> of it (the robot's sizes as
// constants).
template <int W, class Model, class IO, bool kEarlyOutputs>
__global__ void __launch_bounds__(kWarpKernelThreads)
    warp_fused_kernel(ModelView<double> model, BatchPointers<IO> batch) {
  warp_fused_block<W, Model, IO, kEarlyOutputs>(Model(model), batch);
}

// The same with the inputs in the parameters (read in place: __grid_constant__, no copy)
template <int W, class Model, class IO, std::size_t kBytes>
__global__ void __launch_bounds__(kWarpKernelThreads)
    warp_fused_inline_kernel(ModelView<double> model, BatchPointers<IO> batch,
                             const __grid_constant__ WarpInlineBlock<kBytes> inputs) {
  const Model m(model);
  const IO* in = reinterpret_cast<const IO*>(inputs.bytes);
  const std::uint64_t values = batch.n * static_cast<std::uint64_t>(m.nv);
  batch.q = in;
  batch.qd = in + values;
  batch.u = in + 2 * values;
  warp_fused_block<W, Model, IO, false>(m, batch);
}
#endif

}  // namespace rbdgrad::cuda
