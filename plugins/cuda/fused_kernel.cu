// The completely fused kernel: every output of every state of a batch in one launch. A thread
// owns one workspace slot and runs the serial algorithms of device/fused_state.hpp on its states.
#include <algorithm>

#include "fused_launch.hpp"

namespace rbdgrad::cuda {
namespace {

template <class S>
__global__ void __launch_bounds__(kFusedThreadsPerBlock)
    fused_kernel(ModelView<S> model, S* d_scratch, std::size_t slots, BatchPointers<S> batch) {
  const std::size_t slot = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  const std::size_t threads = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  if (slot >= slots) return;
  const WorkspaceView<S> ws(d_scratch, slot, slots, model.nv);
  for (std::uint64_t k = slot; k < batch.n; k += threads) batch.status[k] = evaluate_state(model, ws, batch, k);
}

}  // namespace

template <class S>
cudaError_t launch_fused(const ModelView<S>& model, S* scratch, std::size_t slots, const BatchPointers<S>& batch,
                         cudaStream_t stream) {
  // no more threads than states or slots; slots is a multiple of the block size
  const std::size_t per_block = kFusedThreadsPerBlock;
  const std::size_t wanted = (static_cast<std::size_t>(batch.n) + per_block - 1) / per_block * per_block;
  const std::size_t threads = std::min(slots, wanted);
  const auto blocks = static_cast<unsigned>(threads / per_block);
  fused_kernel<S><<<blocks, kFusedThreadsPerBlock, 0, stream>>>(model, scratch, slots, batch);
  return cudaGetLastError();
}

template cudaError_t launch_fused<double>(const ModelView<double>&, double*, std::size_t, const BatchPointers<double>&,
                                          cudaStream_t);
template cudaError_t launch_fused<float>(const ModelView<float>&, float*, std::size_t, const BatchPointers<float>&,
                                         cudaStream_t);

}  // namespace rbdgrad::cuda
