// Compiled robot-specific kernels, found by a hash of everything that goes into a compilation (the
// source, the embedded headers, the options, NVRTC's version): in memory for the life of the
// process, so that instances of the same model share one compilation, and in a directory, so that
// a restarted daemon loads the kernel instead of compiling it again.
#pragma once

#include <string>

#include "nvrtc_compiler.hpp"

namespace rbdgrad::cuda {

/// Where a compiled kernel came from.
enum class KernelOrigin { kCompiled, kMemoryCache, kDiskCache };
const char* kernel_origin_name(KernelOrigin origin);

/// The default directory of the disk cache: $XDG_CACHE_HOME/rbdgrad/cuda-kernels, else
/// $HOME/.cache/rbdgrad/cuda-kernels, else "" (no disk cache).
std::string default_kernel_cache_dir();

/// The hex key of `program` compiled by NVRTC `nvrtc_version`.
std::string kernel_cache_key(const NvrtcProgram& program, const std::string& nvrtc_version);

/// `program` compiled, from the caches when they hold it. `dir` "" keeps the cache in memory only.
/// A cache file that cannot be read or written is ignored (the kernel is compiled; the message of
/// a failed write goes to `warning`). `refresh` compiles even when a cache holds the kernel, and
/// replaces what the caches held (for a cached cubin that the driver refused). Errors: those of
/// nvrtc_compile.
Status compile_with_cache(const NvrtcProgram& program, const std::string& dir, bool refresh, NvrtcOutput& out,
                          KernelOrigin& origin, std::string& warning);

}  // namespace rbdgrad::cuda
