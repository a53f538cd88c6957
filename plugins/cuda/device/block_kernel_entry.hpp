// The block kernel's entry point: a group of blockDim.x threads per state, blockDim.y states per
// block, the robot's constants and each state's working set in the block's shared memory
// (block_fused_state.hpp). One source for both builds of it: nvcc compiles it for any robot with
// Model = ModelView<S> (block_kernel.cu), NVRTC for one robot with its sizes fixed
// (FixedSizeModelView, kernel_source.cpp).
#pragma once

#include "block_fused_state.hpp"

namespace rbdgrad::cuda {

// Bytes of the robot's constants at the start of a block's shared memory (16-byte aligned).
template <class S>
RBDGRAD_HD std::size_t block_model_bytes(int nv) {
  const std::size_t bytes = ModelLayout::scalars(nv) * sizeof(S) + ModelLayout::ints(nv) * sizeof(int);
  return (bytes + 15) / 16 * 16;
}

#if defined(__CUDACC__)
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// Measurement builds only (never NVRTC's): state 0's clocks, [0] at the kernel's entry, [1]
// before the first pass (after the inputs and the robot's constants are loaded), [k + 1] after the
// k-th sync. Defined here: block_kernel.cu is the one file nvcc compiles this part in.
__device__ long long g_block_pass_clocks[ThreadGroup::kMaxPassClocks];
#endif

// IO: the batch's scalar type, S or (an f32 batch computed in f64) float. kStages: a scene's
// fixed stages (block_stages), or decided per batch.
template <class S, class Model, class IO = S, int kStages = block_stages::kPerBatch>
__global__ void block_fused_kernel(ModelView<S> global_model, BatchPointers<IO> batch) {
  extern __shared__ __align__(16) unsigned char shared[];
  const int nv = FixedSizes<Model>::nv > 0 ? FixedSizes<Model>::nv : global_model.nv;
  // the robot's constants into shared memory first, by the whole block: the passes read them
  // over and over, and a chain of global loads (parent of parent ...) would cost a round trip each
  const int scalars = ModelLayout::scalars(nv), ints = ModelLayout::ints(nv);
  S* model_scalars = reinterpret_cast<S*>(shared);
  int* model_ints = reinterpret_cast<int*>(model_scalars + scalars);
  const int threads = static_cast<int>(blockDim.x * blockDim.y);
  const int tid = static_cast<int>(threadIdx.y * blockDim.x + threadIdx.x);
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (blockIdx.x == 0 && tid == 0) g_block_pass_clocks[0] = clock64();
#endif

  const bool with_aba = block_uses_aba<S>(batch.tau_input);
  S* base = reinterpret_cast<S*>(shared + block_model_bytes<S>(nv)) +
            threadIdx.y * BlockWorkspace<S>::scalars(nv, with_aba);
  const BlockWorkspace<S> w(base, nv, with_aba);
  ThreadGroup g;
  g.rank = static_cast<int>(threadIdx.x);
  g.size = static_cast<int>(blockDim.x);
  // groups that tile whole warps sync as warps (cheaper than the whole block)
  g.warp_sync = blockDim.x <= 32 && 32 % blockDim.x == 0 && (blockDim.x * blockDim.y) % 32 == 0;
  const std::uint64_t k = static_cast<std::uint64_t>(blockIdx.x) * blockDim.y + threadIdx.y;
  const bool active = k < batch.n;
  // the state's inputs first: their reads (host memory over PCIe for small batches) overlap the
  // constants' below
  block_load_inputs(nv, w, batch, active ? k : batch.n - 1, g);
  for (int e = tid; e < scalars; e += threads) model_scalars[e] = global_model.joint_rotation[e];
  for (int e = tid; e < ints; e += threads) model_ints[e] = global_model.parent[e];
  __syncthreads();
  const Model model(model_view(nv, global_model.levels, model_scalars, model_ints, global_model.gravity));
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (k == 0) {
    g.clocks = g_block_pass_clocks + 2;
    if (g.rank == 0) g_block_pass_clocks[1] = clock64();
  }
#endif
  block_evaluate_state<S, Model, IO, kStages>(model, w, batch, active ? k : batch.n - 1, active, g);
}
#endif

}  // namespace rbdgrad::cuda
