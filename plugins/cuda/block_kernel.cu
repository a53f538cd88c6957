// The block kernel: a group of threads_per_state threads per state, states_per_block states per
// block, each state's working set in the block's shared memory (device/block_fused_state.hpp).
#include "block_launch.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
// the clocks of state 0's group: [0] at the kernel's entry, [1] before the first pass (after the
// inputs and the robot's constants are loaded), [k + 1] after the k-th sync
__device__ long long g_block_pass_clocks[ThreadGroup::kMaxPassClocks];

cudaError_t read_block_pass_clocks(long long* out, int count) {
  return cudaMemcpyFromSymbol(out, g_block_pass_clocks, sizeof(long long) * static_cast<std::size_t>(count));
}
#endif

namespace {

template <class S>
__global__ void block_fused_kernel(ModelView<S> global_model, BatchPointers<S> batch) {
  extern __shared__ __align__(16) unsigned char shared[];
  const int nv = global_model.nv;
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
  const ModelView<S> model = model_view(nv, global_model.levels, model_scalars, model_ints, global_model.gravity);
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  if (k == 0) {
    g.clocks = g_block_pass_clocks + 2;
    if (g.rank == 0) g_block_pass_clocks[1] = clock64();
  }
#endif
  block_evaluate_state(model, w, batch, active ? k : batch.n - 1, active, g);
}

}  // namespace

template <class S>
cudaError_t allow_block_shared_bytes(std::size_t bytes) {
  return cudaFuncSetAttribute(block_fused_kernel<S>, cudaFuncAttributeMaxDynamicSharedMemorySize,
                              static_cast<int>(bytes));
}

template <class S>
cudaError_t launch_block_fused(const ModelView<S>& model, const BatchPointers<S>& batch, const BlockShape& shape,
                               cudaStream_t stream) {
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  const auto blocks = static_cast<unsigned>((batch.n + per_block - 1) / per_block);
  const dim3 threads(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  block_fused_kernel<S><<<blocks, threads, block_shared_bytes<S>(model.nv, batch.tau_input, shape), stream>>>(model, batch);
  return cudaGetLastError();
}

template cudaError_t allow_block_shared_bytes<double>(std::size_t);
template cudaError_t allow_block_shared_bytes<float>(std::size_t);
template cudaError_t launch_block_fused<double>(const ModelView<double>&, const BatchPointers<double>&,
                                                const BlockShape&, cudaStream_t);
template cudaError_t launch_block_fused<float>(const ModelView<float>&, const BatchPointers<float>&, const BlockShape&,
                                               cudaStream_t);

}  // namespace rbdgrad::cuda
