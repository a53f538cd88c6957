// The block kernel's entry point: a group of blockDim.x threads per state, blockDim.y states per
// block, the robot's constants and each state's working set in the block's shared memory
// (block_fused_state.hpp). One source for both builds of it: nvcc compiles it for any robot with
// Model = ModelView<S> (block_kernel.cu), NVRTC for one robot with its sizes fixed
// (FixedSizeModelView, kernel_source.cpp).
#pragma once

#include "block_fused_state.hpp"

namespace rbdgrad::cuda {

// The compact block kernel (kCompact) fits more states an SM where shared memory is what limits
// them (talos_reduced: four where the other takes three): the robot's scalar constants stay in
// device memory (the placement and inertia passes read each once), only its tree goes to shared
// memory, and M, M^-1 and d tau/d u are packed by the roots' blocks (ModelView::matrix_row; a
// caller's M^-1 stays dense). The NVRTC build caps its registers to match (register_cap.hpp).
// Its lean working set (kLean, block_workspace.hpp) is smaller again: the inertias and B's and
// Bc's symmetric parts by their parameters, their other parts by the momenta, each array placed
// by its lifetime (talos_reduced: eight an SM at 128 threads a state).

// The robot's ints a block copies to shared memory: the tree, and (compact) where the packed
// matrices' rows start (the last of ModelLayout's ints, ModelView::matrix_row)
RBDGRAD_HD int block_model_ints(int nv, bool compact) {
  return compact ? ModelLayout::ints(nv) : ModelLayout::matrix_row(nv);
}

// Bytes of the robot's constants at the start of a block's shared memory (16-byte aligned): its
// scalars and its tree, or (compact) its tree alone.
template <class S>
RBDGRAD_HD std::size_t block_model_bytes(int nv, bool compact = false) {
  const std::size_t bytes =
      (compact ? 0 : ModelLayout::scalars(nv) * sizeof(S)) + block_model_ints(nv, compact) * sizeof(int);
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
// fixed stages (block_stages), or decided per batch. kCompact, kLean (only with kCompact): above.
template <class S, class Model, class IO = S, int kStages = block_stages::kPerBatch, bool kCompact = false,
          bool kLean = false>
__global__ void block_fused_kernel(ModelView<S> global_model, BatchPointers<IO> batch) {
  extern __shared__ __align__(16) unsigned char shared[];
  const int nv = FixedSizes<Model>::nv > 0 ? FixedSizes<Model>::nv : global_model.nv;
  // the robot's constants into shared memory first, by the whole block: the passes read them
  // over and over, and a chain of global loads (parent of parent ...) would cost a round trip each
  // (compact: the tree alone)
  const int scalars = kCompact ? 0 : ModelLayout::scalars(nv), ints = block_model_ints(nv, kCompact);
  S* model_scalars = reinterpret_cast<S*>(shared);
  int* model_ints = reinterpret_cast<int*>(model_scalars + scalars);
  const int threads = static_cast<int>(blockDim.x * blockDim.y);
  const int tid = static_cast<int>(threadIdx.y * blockDim.x + threadIdx.x);
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (blockIdx.x == 0 && tid == 0) g_block_pass_clocks[0] = clock64();
#endif

  const bool with_aba = block_uses_aba<S>(batch.tau_input);
  // block_matrices(nv, global_model.matrix_scalars, kCompact, batch.minv != nullptr) written out:
  // through the call ptxas spills the compact kernel at its register cap (CUDA 13.0: 12 bytes),
  // in this form it does not (KernelSource.CompactTalosKernelHoldsItsRegisterCapWithoutSpills);
  // the packed size a constant where the model type fixes it (the lean build)
  constexpr int kFixedMatrixScalars = FixedSizes<Model>::matrix_scalars;
  const int matrix_scalars = kFixedMatrixScalars > 0 ? kFixedMatrixScalars
                             : kCompact              ? global_model.matrix_scalars
                                                     : nv * nv;
  const BlockMatrices matrices{matrix_scalars, kCompact && batch.minv == nullptr ? matrix_scalars : nv * nv,
                               batch.minv != nullptr};
  S* base = reinterpret_cast<S*>(shared + block_model_bytes<S>(nv, kCompact)) +
            threadIdx.y * BlockWorkspace<S>::scalars(nv, with_aba, matrices, kLean);
  const BlockWorkspace<S> w(base, nv, with_aba, matrices, kLean);
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
  // (the other kernel's view has no matrix_row in shared memory, and its passes do not read one)
  const Model model(model_view(nv, global_model.levels, global_model.matrix_scalars,
                               kCompact ? global_model.joint_rotation : model_scalars, model_ints,
                               global_model.gravity));
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (k == 0) {
    g.clocks = g_block_pass_clocks + 2;
    if (g.rank == 0) g_block_pass_clocks[1] = clock64();
  }
#endif
  // (a launch's states are at most kDefaultBlockMaxStates: a 32-bit index, one register where
  // 64 bits took two, which the kernel held or spilled through all its passes)
  const auto state = static_cast<std::uint32_t>(active ? k : batch.n - 1);
  block_evaluate_state<S, Model, IO, kStages, kCompact, kLean>(model, w, batch, state, active, g);
}
#endif

}  // namespace rbdgrad::cuda
