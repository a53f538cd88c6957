// The warp kernel compiled for one robot (its joint count and tree depth as constants,
// kernel_source.hpp): compiled with NVRTC and loaded (compiled_library.hpp) when an instance is
// created, its entry points handed to launch_warp_fused as a WarpKernelTable. Without it (no NVRTC,
// a failed compilation) the generic warp kernel runs.
#pragma once

#include <memory>
#include <string>

#include "compiled_library.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"
#include "warp_launch.hpp"

namespace rbdgrad::cuda {

class SpecializedWarpKernel {
 public:
  /// Builds the entry points of `model` (nv <= kMaxWarpNv) for f64 batches and, with
  /// f32_batches, for f32 batches computed in f64, on `device` (current). `cache_dir` as
  /// compile_with_cache's dir. Errors: as CompiledLibrary::load; invalid_argument for a model too
  /// large for the warp kernel.
  static Status load(const Model& model, bool f32_batches, int device, const std::string& cache_dir,
                     std::unique_ptr<SpecializedWarpKernel>& out);

  const WarpKernelTable& table() const { return table_; }
  const CompiledLibrary& library() const { return *library_; }

 private:
  SpecializedWarpKernel() = default;

  std::unique_ptr<CompiledLibrary> library_;
  WarpKernelTable table_;
};

}  // namespace rbdgrad::cuda
