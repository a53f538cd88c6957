// The host's entry to the block kernel (block_kernel.cu): a group of threads per state, the
// state's working set in shared memory (device/block_fused_state.hpp). It takes the gradient
// requests (block_kernel_supports); the one-thread kernel (fused_launch.hpp) takes the rest.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>

#include "device/block_fused_state.hpp"

namespace rbdgrad::cuda {

/// Threads per state and states per block: a block is threads_per_state x states_per_block.
struct BlockShape {
  int threads_per_state = 64;
  int states_per_block = 1;
};

/// Shared memory of one block of `shape` for a model of nv joints, in bytes.
template <class S>
std::size_t block_shared_bytes(int nv, bool tau_input, const BlockShape& shape) {
  return BlockWorkspace<S>::scalars(nv, block_uses_aba<S>(tau_input)) * sizeof(S) *
         static_cast<std::size_t>(shape.states_per_block);
}

/// Lets the kernel use up to `bytes` of shared memory per block (the device's opt-in limit);
/// once per device before the first launch.
template <class S>
cudaError_t allow_block_shared_bytes(std::size_t bytes);

/// Enqueues the kernel on `stream` for every state of `batch` (block_kernel_supports(batch), its
/// shared memory within what allow_block_shared_bytes allowed).
/// \return the launch error, if any (execution errors show at the next synchronisation).
template <class S>
cudaError_t launch_block_fused(const ModelView<S>& model, const BatchPointers<S>& batch, const BlockShape& shape,
                               cudaStream_t stream);

}  // namespace rbdgrad::cuda
