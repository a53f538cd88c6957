// The host's entry to the block kernel (block_kernel.cu): a group of threads per state, the
// state's working set in shared memory (device/block_fused_state.hpp). It takes the gradient
// requests (block_kernel_supports); the one-thread kernel (fused_launch.hpp) takes the rest.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>

#include "device/block_kernel_entry.hpp"

namespace rbdgrad::cuda {

/// Threads per state and states per block: a block is threads_per_state x states_per_block.
/// threads_per_state 0 chooses by the batch and model size (block_shape_for).
struct BlockShape {
  int threads_per_state = 0;
  int states_per_block = 1;
};

/// The shape a launch of n states uses (n: the states of one launch, a pipelined batch's chunk).
/// An automatic threads_per_state (measured on an H200, docs/benchmarks/cuda.md): 256 for launches
/// of up to kWideStates, which leave most of the GPU idle, so that the latency of one state is
/// what counts; for larger ones 8 per joint, rounded up to a power of two, from 64 to 256 (64 is
/// the fastest for iiwa14 there, 256 for talos_reduced). The compact kernel's lean working set
/// (`lean`, block_workspace.hpp) takes at most kLeanThreadsPerState for larger ones: eight
/// talos_reduced states an SM at 64 registers a thread (seven at 72 before its working set lost
/// I, v and a after the subtree sums), where at 256 threads its registers allow three
/// (register_cap.hpp); on an H200 its kernel (seven states an SM then) at 65536 states 21% faster
/// at 128 than at 256, at 1024 states (eight chunks of 128) 29% slower.
inline constexpr std::size_t kWideStates = 256;
inline constexpr int kLeanThreadsPerState = 128;
inline BlockShape block_shape_for(const BlockShape& requested, int nv, std::size_t n, bool lean = false) {
  BlockShape shape = requested;
  if (shape.threads_per_state == 0) {
    int t = 64;
    while (t < 8 * nv && t < 256) t *= 2;
    if (lean && t > kLeanThreadsPerState) t = kLeanThreadsPerState;
    shape.threads_per_state = n <= kWideStates ? 256 : t;
  }
  return shape;
}

/// Shared memory of one block of `shape` (resolved) for a model of nv joints, in bytes: the
/// robot's constants, then each state's working set.
template <class S>
std::size_t block_shared_bytes(int nv, bool tau_input, const BlockShape& shape) {
  return block_model_bytes<S>(nv) + BlockWorkspace<S>::scalars(nv, block_uses_aba<S>(tau_input)) * sizeof(S) *
                                        static_cast<std::size_t>(shape.states_per_block);
}
/// The same for the compact kernel (block_kernel_entry.hpp), whose working set depends on whether
/// the batch brings M^-1, and (lean) on its layout; at most the above.
template <class S, class IO>
std::size_t compact_block_shared_bytes(const ModelView<S>& model, const BatchPointers<IO>& batch,
                                       const BlockShape& shape, bool lean = false) {
  return block_model_bytes<S>(model.nv, true) +
         block_state_scalars(model, batch.tau_input, batch.minv != nullptr, true, lean) * sizeof(S) *
             static_cast<std::size_t>(shape.states_per_block);
}

/// Lets the kernel (S computing, IO the batch's scalars) use up to `bytes` of shared memory per
/// block (the device's opt-in limit); once per device before the first launch.
template <class S, class IO = S>
cudaError_t allow_block_shared_bytes(std::size_t bytes);

/// Enqueues the kernel on `stream` for every state of `batch` (block_kernel_supports(batch), its
/// shared memory within what allow_block_shared_bytes allowed; `shape` resolved), computing in S:
/// IO is S, or float with S double (an f32 batch computed in f64).
/// \return the launch error, if any (execution errors show at the next synchronisation).
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
/// Measurement builds: the SM clock of state 0's group before the first pass and after each
/// sync of the last launch (count <= ThreadGroup::kMaxPassClocks).
cudaError_t read_block_pass_clocks(long long* out, int count);
#endif

template <class S, class IO>
cudaError_t launch_block_fused(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape,
                               cudaStream_t stream);

/// One launch of a block kernel, for launching it by other means than a stream call (a CUDA
/// Graph's kernel node, kernel_graphs.hpp): the kernel, its grid and block, its shared memory.
/// Its arguments are the model view and the batch pointers, in that order.
struct KernelLaunch {
  const void* function = nullptr;
  dim3 grid, block;
  std::size_t shared_bytes = 0;
};
/// The launch launch_block_fused would make.
template <class S, class IO>
KernelLaunch block_fused_launch(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape);

}  // namespace rbdgrad::cuda
