// The block kernel for any robot (device/block_kernel_entry.hpp with run-time sizes): a group of
// threads_per_state threads per state, states_per_block states per block.
#include "block_launch.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// the clocks of state 0's group (device/block_kernel_entry.hpp)
cudaError_t read_block_pass_clocks(long long* out, int count) {
  return cudaMemcpyFromSymbol(out, g_block_pass_clocks, sizeof(long long) * static_cast<std::size_t>(count));
}
#endif

template <class S, class IO>
cudaError_t allow_block_shared_bytes(std::size_t bytes) {
  return cudaFuncSetAttribute(block_fused_kernel<S, ModelView<S>, IO>, cudaFuncAttributeMaxDynamicSharedMemorySize,
                              static_cast<int>(bytes));
}

template <class S, class IO>
cudaError_t launch_block_fused(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape,
                               cudaStream_t stream) {
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  const auto blocks = static_cast<unsigned>((batch.n + per_block - 1) / per_block);
  const dim3 threads(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  block_fused_kernel<S, ModelView<S>, IO>
      <<<blocks, threads, block_shared_bytes<S>(model.nv, batch.tau_input, shape), stream>>>(model, batch);
  return cudaGetLastError();
}

template <class S, class IO>
KernelLaunch block_fused_launch(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape) {
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  KernelLaunch l;
  l.function = reinterpret_cast<const void*>(block_fused_kernel<S, ModelView<S>, IO>);
  l.grid = dim3(static_cast<unsigned>((batch.n + per_block - 1) / per_block));
  l.block = dim3(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  l.shared_bytes = block_shared_bytes<S>(model.nv, batch.tau_input, shape);
  return l;
}

template KernelLaunch block_fused_launch<double, double>(const ModelView<double>&, const BatchPointers<double>&,
                                                         const BlockShape&);
template KernelLaunch block_fused_launch<float, float>(const ModelView<float>&, const BatchPointers<float>&,
                                                       const BlockShape&);
template KernelLaunch block_fused_launch<double, float>(const ModelView<double>&, const BatchPointers<float>&,
                                                        const BlockShape&);
template cudaError_t allow_block_shared_bytes<double, double>(std::size_t);
template cudaError_t allow_block_shared_bytes<float, float>(std::size_t);
template cudaError_t allow_block_shared_bytes<double, float>(std::size_t);
template cudaError_t launch_block_fused<double, double>(const ModelView<double>&, const BatchPointers<double>&,
                                                        const BlockShape&, cudaStream_t);
template cudaError_t launch_block_fused<float, float>(const ModelView<float>&, const BatchPointers<float>&,
                                                      const BlockShape&, cudaStream_t);
template cudaError_t launch_block_fused<double, float>(const ModelView<double>&, const BatchPointers<float>&,
                                                       const BlockShape&, cudaStream_t);

}  // namespace rbdgrad::cuda
