#include "specialized_kernel.hpp"

#include <type_traits>

#include "cuda_device.hpp"
#include "flat_model.hpp"

namespace rbdgrad::cuda {

int compact_register_cap(const Model& model, bool lean, const BlockShape& shape, const SmLimits& sm) {
  const FlatModel<double> flat(model);
  BatchPointers<double> batch;
  batch.tau_input = true;
  const BlockShape large = block_shape_for(shape, model.nv, kWideStates + 1, lean);
  return block_register_cap(sm, compact_block_shared_bytes(flat.host_view(), batch, large, lean),
                            large.threads_per_state * large.states_per_block);
}

namespace {

// compact_register_cap on `device`'s SM
Status device_register_cap(const Model& model, bool lean, const BlockShape& shape, int device, int& cap) {
  cudaDeviceProp prop{};
  if (Status s = cuda_status(cudaGetDeviceProperties(&prop, device), "cudaGetDeviceProperties"); !s) return s;
  SmLimits sm;
  sm.shared_bytes = prop.sharedMemPerMultiprocessor;
  sm.reserved_shared_bytes = prop.reservedSharedMemPerBlock;
  sm.registers = prop.regsPerMultiprocessor;
  sm.max_threads = prop.maxThreadsPerMultiProcessor;
  sm.max_blocks = prop.maxBlocksPerMultiProcessor;
  cap = compact_register_cap(model, lean, shape, sm);
  return Status::ok();
}

}  // namespace

Status SpecializedBlockKernel::load(const Model& model, KernelScalars scalars, int stages, const BlockBuild& wanted,
                                    const BlockShape& shape, int device, std::size_t max_shared_bytes,
                                    const std::string& cache_dir,
                                    std::unique_ptr<SpecializedBlockKernel>& out) {
  int arch = 0;
  if (Status s = device_arch(device, arch); !s) return s;
  std::unique_ptr<SpecializedBlockKernel> k(new SpecializedBlockKernel());
  k->scalars_ = scalars;
  k->build_.compact = wanted.compact;
  k->build_.lean = wanted.compact && wanted.lean;
  k->build_.tree_chains = k->build_.lean && wanted.tree_chains;
  k->build_.tree_columns = k->build_.tree_chains && wanted.tree_columns;
  if (wanted.compact && register_capped(scalars))
    if (Status s = device_register_cap(model, k->build_.lean, shape, device, k->build_.register_cap); !s) return s;
  if (Status s = CompiledLibrary::load(block_kernel_program(model, scalars, arch, stages, k->build_), device,
                                       max_shared_bytes, cache_dir, k->library_);
      !s)
    return s;
  out = std::move(k);
  return Status::ok();
}

template <class S, class IO>
std::size_t SpecializedBlockKernel::shared_bytes(const ModelView<S>& model, const BatchPointers<IO>& batch,
                                                 const BlockShape& shape) const {
  return build_.compact ? compact_block_shared_bytes(model, batch, shape, build_.lean)
                        : block_shared_bytes<S>(model.nv, batch.tau_input, shape);
}

template <class S, class IO>
cudaError_t SpecializedBlockKernel::launch(const ModelView<S>& model, const BatchPointers<IO>& batch,
                                           const BlockShape& shape, cudaStream_t stream) const {
  const KernelScalars built_for = std::is_same_v<S, float>  ? KernelScalars::kF32
                                  : std::is_same_v<IO, float> ? KernelScalars::kF64ForF32
                                                              : KernelScalars::kF64;
  if (scalars_ != built_for) return cudaErrorInvalidValue;
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  const dim3 blocks(static_cast<unsigned>((batch.n + per_block - 1) / per_block));
  const dim3 threads(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  // the kernel's parameters, as block_fused_kernel takes them
  ModelView<S> model_arg = model;
  BatchPointers<IO> batch_arg = batch;
  void* args[] = {&model_arg, &batch_arg};
  return cudaLaunchKernel(library_->kernel(0), blocks, threads, args, shared_bytes(model, batch, shape), stream);
}

template <class S, class IO>
bool SpecializedBlockKernel::launch_config(const ModelView<S>& model, const BatchPointers<IO>& batch,
                                           const BlockShape& shape, KernelLaunch& out) const {
  const KernelScalars built_for = std::is_same_v<S, float>  ? KernelScalars::kF32
                                  : std::is_same_v<IO, float> ? KernelScalars::kF64ForF32
                                                              : KernelScalars::kF64;
  if (scalars_ != built_for) return false;
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  out.function = library_->kernel(0);
  out.grid = dim3(static_cast<unsigned>((batch.n + per_block - 1) / per_block));
  out.block = dim3(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  out.shared_bytes = shared_bytes(model, batch, shape);
  return true;
}

template bool SpecializedBlockKernel::launch_config<double, double>(const ModelView<double>&,
                                                                    const BatchPointers<double>&, const BlockShape&,
                                                                    KernelLaunch&) const;
template bool SpecializedBlockKernel::launch_config<float, float>(const ModelView<float>&, const BatchPointers<float>&,
                                                                  const BlockShape&, KernelLaunch&) const;
template bool SpecializedBlockKernel::launch_config<double, float>(const ModelView<double>&,
                                                                   const BatchPointers<float>&, const BlockShape&,
                                                                   KernelLaunch&) const;

template cudaError_t SpecializedBlockKernel::launch<double, double>(const ModelView<double>&,
                                                                    const BatchPointers<double>&, const BlockShape&,
                                                                    cudaStream_t) const;
template cudaError_t SpecializedBlockKernel::launch<float, float>(const ModelView<float>&, const BatchPointers<float>&,
                                                                  const BlockShape&, cudaStream_t) const;
template cudaError_t SpecializedBlockKernel::launch<double, float>(const ModelView<double>&,
                                                                   const BatchPointers<float>&, const BlockShape&,
                                                                   cudaStream_t) const;

}  // namespace rbdgrad::cuda
