// The warp kernel for any robot of up to kMaxWarpNv joints (device/warp_fused_state.hpp), one
// instantiation per segment width (8 or 16 lanes).
#include "warp_launch.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// state 0's clocks: [0] at the kernel's entry, then at the end of each stage (WarpLanes::stamp)
__device__ long long g_warp_stage_clocks[WarpLanes<8>::kMaxStageClocks + 1];
cudaError_t read_warp_stage_clocks(long long* out, int count) {
  return cudaMemcpyFromSymbol(out, g_warp_stage_clocks, sizeof(long long) * static_cast<std::size_t>(count));
}
#endif

template <int W, class IO>
__global__ void __launch_bounds__(kWarpKernelThreads) warp_fused_kernel(ModelView<double> model, BatchPointers<IO> batch) {
  extern __shared__ __align__(16) unsigned char shared[];
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
  double* sh = reinterpret_cast<double*>(shared) + slot * WarpShared<W>::kScalars;
  warp_evaluate_state<W, double, IO, block_stages::kPerBatch>(model, sh, batch, active ? k : batch.n - 1, active, g);
}

namespace {

template <class IO>
KernelLaunch launch_for(int W, std::uint64_t n) {
  KernelLaunch l;
  const int per_block = kWarpKernelThreads / W;
  l.function = W == 8 ? reinterpret_cast<const void*>(warp_fused_kernel<8, IO>)
                      : reinterpret_cast<const void*>(warp_fused_kernel<16, IO>);
  const int scalars = W == 8 ? WarpShared<8>::kScalars : WarpShared<16>::kScalars;
  l.grid = dim3(static_cast<unsigned>((n + per_block - 1) / per_block));
  l.block = dim3(kWarpKernelThreads);
  l.shared_bytes = static_cast<std::size_t>(scalars) * sizeof(double) * static_cast<std::size_t>(per_block);
  return l;
}

}  // namespace

template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch) {
  return launch_for<IO>(warp_segment_width(model.nv), batch.n);
}

template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch, cudaStream_t stream) {
  const KernelLaunch l = warp_fused_launch(model, batch);
  ModelView<double> model_arg = model;
  BatchPointers<IO> batch_arg = batch;
  void* args[] = {&model_arg, &batch_arg};
  if (const cudaError_t e = cudaLaunchKernel(l.function, l.grid, l.block, args, l.shared_bytes, stream); e != cudaSuccess)
    return e;
  return cudaGetLastError();
}

template KernelLaunch warp_fused_launch<double>(const ModelView<double>&, const BatchPointers<double>&);
template KernelLaunch warp_fused_launch<float>(const ModelView<double>&, const BatchPointers<float>&);
template cudaError_t launch_warp_fused<double>(const ModelView<double>&, const BatchPointers<double>&, cudaStream_t);
template cudaError_t launch_warp_fused<float>(const ModelView<double>&, const BatchPointers<float>&, cudaStream_t);

}  // namespace rbdgrad::cuda
