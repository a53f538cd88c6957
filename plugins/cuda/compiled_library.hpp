// A robot-specific program (kernel_source.hpp) compiled with NVRTC, from the caches where they
// hold it (kernel_cache.hpp), and loaded onto a device: its kernels in the order of the program's
// name expressions. The robot-specific block and warp kernels (specialized_kernel.hpp,
// specialized_warp_kernel.hpp) are each one of these.
#pragma once

#include <cuda_runtime_api.h>

#include <memory>
#include <string>
#include <vector>

#include "kernel_cache.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

/// sm_<arch> of `device`: 90 for compute capability 9.0.
Status device_arch(int device, int& arch);

class CompiledLibrary {
 public:
  /// Compiles `program` (or takes it from the caches: `cache_dir` as compile_with_cache's dir) and
  /// loads it onto `device` (current), each kernel's shared memory allowed up to
  /// `max_shared_bytes`. A cached cubin the driver refuses is compiled again. Errors: unavailable
  /// (no NVRTC), internal (compiling or loading failed: the message says which).
  static Status load(const NvrtcProgram& program, int device, std::size_t max_shared_bytes,
                     const std::string& cache_dir, std::unique_ptr<CompiledLibrary>& out);
  ~CompiledLibrary();
  CompiledLibrary(const CompiledLibrary&) = delete;
  CompiledLibrary& operator=(const CompiledLibrary&) = delete;

  /// The kernel of the program's name_expressions[i], as cudaLaunchKernel takes it.
  const void* kernel(std::size_t i) const { return reinterpret_cast<const void*>(kernels_.at(i)); }
  std::size_t size() const { return kernels_.size(); }
  KernelOrigin origin() const { return origin_; }
  /// Seconds spent compiling (0 from a cache) and loading.
  double seconds() const { return seconds_; }
  /// A failed write to the disk cache, else "".
  const std::string& warning() const { return warning_; }
  /// "compiled, 2.1 s", "disk cache, 0.1 s", then the warning where there is one: for logs.
  std::string description() const;

 private:
  CompiledLibrary() = default;

  cudaLibrary_t library_ = nullptr;
  std::vector<cudaKernel_t> kernels_;
  KernelOrigin origin_ = KernelOrigin::kCompiled;
  double seconds_ = 0;
  std::string warning_;
};

}  // namespace rbdgrad::cuda
