// The warp kernel for any robot of up to kMaxWarpNv joints (device/warp_fused_state.hpp), one
// instantiation per segment width (8 or 16 lanes), place of the first outputs and place of the
// inputs.
#include "warp_launch.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// state 0's clocks: [0] at the kernel's entry, then at the end of each stage (WarpLanes::stamp)
__device__ long long g_warp_stage_clocks[WarpLanes<8>::kMaxStageClocks + 1];
cudaError_t read_warp_stage_clocks(long long* out, int count) {
  return cudaMemcpyFromSymbol(out, g_warp_stage_clocks, sizeof(long long) * static_cast<std::size_t>(count));
}
#endif

// The states of `batch` on the block's warps; kEarlyOutputs: warp_evaluate_state's early_outputs.
template <int W, class IO, bool kEarlyOutputs>
__device__ __forceinline__ void warp_fused_block(const ModelView<double>& model, const BatchPointers<IO>& batch) {
  extern __shared__ __align__(32) unsigned char shared[];  // 32: the tensor cores' loads (WarpLanes::product)
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

template <int W, class IO, bool kEarlyOutputs>
__global__ void __launch_bounds__(kWarpKernelThreads) warp_fused_kernel(ModelView<double> model, BatchPointers<IO> batch) {
  warp_fused_block<W, IO, kEarlyOutputs>(model, batch);
}

// The same with the inputs in the parameters (read in place: __grid_constant__, no copy)
template <int W, class IO, std::size_t kBytes>
__global__ void __launch_bounds__(kWarpKernelThreads)
    warp_fused_inline_kernel(ModelView<double> model, BatchPointers<IO> batch,
                             const __grid_constant__ WarpInlineBlock<kBytes> inputs) {
  const IO* in = reinterpret_cast<const IO*>(inputs.bytes);
  const std::uint64_t values = batch.n * static_cast<std::uint64_t>(model.nv);
  batch.q = in;
  batch.qd = in + values;
  batch.u = in + 2 * values;
  warp_fused_block<W, IO, false>(model, batch);
}

namespace {

template <int W, class IO>
const void* kernel_for(bool early_outputs, std::size_t inline_block) {
  if (inline_block == 2048) return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, IO, 2048>);
  if (inline_block == 4096) return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, IO, 4096>);
  if (inline_block != 0)
    return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, IO, kWarpInlineInputBytes>);
  return early_outputs ? reinterpret_cast<const void*>(warp_fused_kernel<W, IO, true>)
                       : reinterpret_cast<const void*>(warp_fused_kernel<W, IO, false>);
}

}  // namespace

template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch,
                               std::uint64_t early_outputs_min_bytes, std::size_t inline_block) {
  const int W = warp_segment_width(model.nv);
  const std::uint64_t n = batch.n;
  KernelLaunch l;
  const int per_block = kWarpKernelThreads / W;
  // the outputs' bytes: qdd n x nv, the matrices n x nv x nv each
  const std::uint64_t nv = static_cast<std::uint64_t>(model.nv);
  std::uint64_t per_state = batch.out[output_index(kOutputQdd)] ? nv : 0;
  for (const std::uint32_t f : {kOutputMinv, kOutputDqddDq, kOutputDqddDqd})
    if (batch.out[output_index(f)]) per_state += nv * nv;
  const bool early = n * per_state * sizeof(IO) >= early_outputs_min_bytes;
  l.function = W == 8 ? kernel_for<8, IO>(early, inline_block) : kernel_for<16, IO>(early, inline_block);
  const int warp_scalars = W == 8 ? WarpShared<8>::warp_scalars(WarpLanes<8>::kSegments)
                                  : WarpShared<16>::warp_scalars(WarpLanes<16>::kSegments);
  l.grid = dim3(static_cast<unsigned>((n + per_block - 1) / per_block));
  l.block = dim3(kWarpKernelThreads);
  l.shared_bytes = static_cast<std::size_t>(warp_scalars) * sizeof(double) * (kWarpKernelThreads / 32);
  return l;
}

template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch,
                              std::uint64_t early_outputs_min_bytes, const WarpInlineInputs* inline_inputs,
                              std::size_t inline_block, cudaStream_t stream) {
  const KernelLaunch l =
      warp_fused_launch(model, batch, early_outputs_min_bytes, inline_inputs != nullptr ? inline_block : 0);
  ModelView<double> model_arg = model;
  BatchPointers<IO> batch_arg = batch;
  void* args[] = {&model_arg, &batch_arg, const_cast<WarpInlineInputs*>(inline_inputs)};
  if (const cudaError_t e = cudaLaunchKernel(l.function, l.grid, l.block, args, l.shared_bytes, stream); e != cudaSuccess)
    return e;
  return cudaGetLastError();
}

template KernelLaunch warp_fused_launch<double>(const ModelView<double>&, const BatchPointers<double>&,
                                                std::uint64_t, std::size_t);
template KernelLaunch warp_fused_launch<float>(const ModelView<double>&, const BatchPointers<float>&, std::uint64_t,
                                               std::size_t);
template cudaError_t launch_warp_fused<double>(const ModelView<double>&, const BatchPointers<double>&, std::uint64_t,
                                               const WarpInlineInputs*, std::size_t, cudaStream_t);
template cudaError_t launch_warp_fused<float>(const ModelView<double>&, const BatchPointers<float>&, std::uint64_t,
                                              const WarpInlineInputs*, std::size_t, cudaStream_t);

}  // namespace rbdgrad::cuda
