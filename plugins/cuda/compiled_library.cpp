#include "compiled_library.hpp"

#include <chrono>
#include <cstdio>

#include "cuda_device.hpp"

namespace rbdgrad::cuda {

namespace {

Status internal(std::string message) { return Status(StatusCode::kInternal, std::move(message)); }

// cudaLibraryLoadData, then each of the `wanted` kernels and its shared-memory allowance
Status load_cubin(const NvrtcOutput& compiled, std::size_t wanted, int device, std::size_t max_shared_bytes,
                  cudaLibrary_t& library, std::vector<cudaKernel_t>& kernels) {
  // a cache file's list that is not the program's (another program's file under a colliding key)
  if (compiled.kernel_symbols.size() != wanted)
    return internal("the compiled program has " + std::to_string(compiled.kernel_symbols.size()) + " kernels, not " +
                    std::to_string(wanted));
  if (cudaError_t e = cudaLibraryLoadData(&library, compiled.cubin.data(), nullptr, nullptr, 0, nullptr, nullptr, 0);
      e != cudaSuccess) {
    cudaGetLastError();
    library = nullptr;
    return internal(std::string("cudaLibraryLoadData: ") + cudaGetErrorString(e));
  }
  kernels.assign(compiled.kernel_symbols.size(), nullptr);
  for (std::size_t i = 0; i < kernels.size(); ++i) {
    cudaError_t e = cudaLibraryGetKernel(&kernels[i], library, compiled.kernel_symbols[i].c_str());
    if (e == cudaSuccess)
      e = cudaKernelSetAttributeForDevice(kernels[i], cudaFuncAttributeMaxDynamicSharedMemorySize,
                                          static_cast<int>(max_shared_bytes), device);
    if (e != cudaSuccess) {
      cudaGetLastError();
      cudaLibraryUnload(library);
      library = nullptr;
      kernels.clear();
      return internal("loading the kernel " + compiled.kernel_symbols[i] + ": " + cudaGetErrorString(e));
    }
  }
  return Status::ok();
}

}  // namespace

Status device_arch(int device, int& arch) {
  int major = 0, minor = 0;
  if (Status s = cuda_status(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device),
                             "cudaDeviceGetAttribute");
      !s)
    return s;
  if (Status s = cuda_status(cudaDeviceGetAttribute(&minor, cudaDevAttrComputeCapabilityMinor, device),
                             "cudaDeviceGetAttribute");
      !s)
    return s;
  arch = 10 * major + minor;
  return Status::ok();
}

Status CompiledLibrary::load(const NvrtcProgram& program, int device, std::size_t max_shared_bytes,
                             const std::string& cache_dir, std::unique_ptr<CompiledLibrary>& out) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t wanted = program.name_expressions.size();
  std::unique_ptr<CompiledLibrary> k(new CompiledLibrary());
  NvrtcOutput compiled;
  if (Status s = compile_with_cache(program, cache_dir, false, compiled, k->origin_, k->warning_); !s) return s;
  Status loaded = load_cubin(compiled, wanted, device, max_shared_bytes, k->library_, k->kernels_);
  if (!loaded && k->origin_ != KernelOrigin::kCompiled) {
    // a cached cubin the driver refuses (a damaged file, a changed driver): compile it again
    if (Status s = compile_with_cache(program, cache_dir, true, compiled, k->origin_, k->warning_); !s) return s;
    loaded = load_cubin(compiled, wanted, device, max_shared_bytes, k->library_, k->kernels_);
  }
  if (!loaded) return loaded;
  k->seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out = std::move(k);
  return Status::ok();
}

std::string CompiledLibrary::description() const {
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.1f s", seconds_);
  return std::string(kernel_origin_name(origin_)) + ", " + seconds + (warning_.empty() ? "" : ", " + warning_);
}

CompiledLibrary::~CompiledLibrary() {
  if (library_) cudaLibraryUnload(library_);
}

}  // namespace rbdgrad::cuda
