#include "specialized_kernel.hpp"

#include <chrono>
#include <type_traits>

#include "cuda_device.hpp"

namespace rbdgrad::cuda {

namespace {

Status internal(std::string message) { return Status(StatusCode::kInternal, std::move(message)); }

// cudaLibraryLoadData, then the kernel and its shared-memory allowance
Status load_cubin(const NvrtcOutput& compiled, int device, std::size_t max_shared_bytes, cudaLibrary_t& library,
                  cudaKernel_t& kernel) {
  if (cudaError_t e = cudaLibraryLoadData(&library, compiled.cubin.data(), nullptr, nullptr, 0, nullptr, nullptr, 0);
      e != cudaSuccess) {
    cudaGetLastError();
    library = nullptr;
    return internal(std::string("cudaLibraryLoadData: ") + cudaGetErrorString(e));
  }
  cudaError_t e = cudaLibraryGetKernel(&kernel, library, compiled.kernel_symbol.c_str());
  if (e == cudaSuccess)
    e = cudaKernelSetAttributeForDevice(kernel, cudaFuncAttributeMaxDynamicSharedMemorySize,
                                        static_cast<int>(max_shared_bytes), device);
  if (e != cudaSuccess) {
    cudaGetLastError();
    cudaLibraryUnload(library);
    library = nullptr;
    return internal(std::string("loading the kernel ") + compiled.kernel_symbol + ": " + cudaGetErrorString(e));
  }
  return Status::ok();
}

}  // namespace

Status SpecializedBlockKernel::load(const Model& model, KernelScalars scalars, int stages, int device,
                                    std::size_t max_shared_bytes,
                                    const std::string& cache_dir, std::unique_ptr<SpecializedBlockKernel>& out) {
  const auto start = std::chrono::steady_clock::now();
  int major = 0, minor = 0;
  if (Status s = cuda_status(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device),
                             "cudaDeviceGetAttribute");
      !s)
    return s;
  if (Status s = cuda_status(cudaDeviceGetAttribute(&minor, cudaDevAttrComputeCapabilityMinor, device),
                             "cudaDeviceGetAttribute");
      !s)
    return s;
  const NvrtcProgram program = block_kernel_program(model, scalars, 10 * major + minor, stages);
  std::unique_ptr<SpecializedBlockKernel> k(new SpecializedBlockKernel());
  k->scalars_ = scalars;
  NvrtcOutput compiled;
  if (Status s = compile_with_cache(program, cache_dir, false, compiled, k->origin_, k->warning_); !s) return s;
  Status loaded = load_cubin(compiled, device, max_shared_bytes, k->library_, k->kernel_);
  if (!loaded && k->origin_ != KernelOrigin::kCompiled) {
    // a cached cubin the driver refuses (a damaged file, a changed driver): compile it again
    if (Status s = compile_with_cache(program, cache_dir, true, compiled, k->origin_, k->warning_); !s) return s;
    loaded = load_cubin(compiled, device, max_shared_bytes, k->library_, k->kernel_);
  }
  if (!loaded) return loaded;
  k->seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out = std::move(k);
  return Status::ok();
}

SpecializedBlockKernel::~SpecializedBlockKernel() {
  if (library_) cudaLibraryUnload(library_);
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
  return cudaLaunchKernel(reinterpret_cast<const void*>(kernel_), blocks, threads, args,
                          block_shared_bytes<S>(model.nv, batch.tau_input, shape), stream);
}

template <class S, class IO>
bool SpecializedBlockKernel::launch_config(const ModelView<S>& model, const BatchPointers<IO>& batch,
                                           const BlockShape& shape, KernelLaunch& out) const {
  const KernelScalars built_for = std::is_same_v<S, float>  ? KernelScalars::kF32
                                  : std::is_same_v<IO, float> ? KernelScalars::kF64ForF32
                                                              : KernelScalars::kF64;
  if (scalars_ != built_for) return false;
  const auto per_block = static_cast<std::uint64_t>(shape.states_per_block);
  out.function = reinterpret_cast<const void*>(kernel_);
  out.grid = dim3(static_cast<unsigned>((batch.n + per_block - 1) / per_block));
  out.block = dim3(static_cast<unsigned>(shape.threads_per_state), static_cast<unsigned>(shape.states_per_block));
  out.shared_bytes = block_shared_bytes<S>(model.nv, batch.tau_input, shape);
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
