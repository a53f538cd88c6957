// The block kernel compiled for one robot: generated (kernel_source.hpp), compiled with NVRTC and
// loaded onto its device (compiled_library.hpp) when an instance is created, and launched as the
// generic one is (block_launch.hpp). When NVRTC is missing or fails, the instance keeps the generic
// kernel, compiled into the plugin for any robot.
#pragma once

#include <cuda_runtime_api.h>

#include <memory>
#include <string>

#include "block_launch.hpp"
#include "compiled_library.hpp"
#include "kernel_source.hpp"
#include "register_cap.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

/// The compact f64 kernel's register cap (register_cap.hpp) on an SM of `sm` for blocks of `shape`
/// (large batches' shape where it is automatic), from its shared memory (lean or not) for a batch
/// from tau without a caller's M^-1. 0: no cap.
int compact_register_cap(const Model& model, bool lean, const BlockShape& shape, const SmLimits& sm);
/// Whether the compact kernel in `scalars` gets that cap: where it computes in f64 (f64 batches,
/// f32 batches computed in f64); the f32 arithmetic's articulated-body pass spills at 64 registers.
inline bool register_capped(KernelScalars scalars) { return scalars != KernelScalars::kF32; }

class SpecializedBlockKernel {
 public:
  /// Builds the kernel of `model` in `scalars` with `stages` (block_stages: a scene's, or
  /// kPerBatch) for `device` (current), its shared memory allowed up to `max_shared_bytes`.
  /// `wanted`: compact, lean, tree_chains and tree_columns as BlockBuild says (each ignored
  /// without the one before it); its register_cap is not read: the kernel's registers are capped
  /// for blocks of `shape` (the instance's, resolved for a large batch) where it computes in f64
  /// (register_cap.hpp; the f32 arithmetic's articulated-body pass spills at 64 registers).
  /// `cache_dir` as compile_with_cache's dir. Errors: unavailable (no NVRTC), internal (compiling
  /// or loading failed: the message says which).
  static Status load(const Model& model, KernelScalars scalars, int stages, const BlockBuild& wanted,
                     const BlockShape& shape, int device, std::size_t max_shared_bytes,
                     const std::string& cache_dir, std::unique_ptr<SpecializedBlockKernel>& out);

  /// As launch_block_fused (block_launch.hpp), S and IO those the kernel was built for (else
  /// cudaErrorInvalidValue).
  template <class S, class IO>
  cudaError_t launch(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape,
                     cudaStream_t stream) const;

  /// The launch launch() would make, for a CUDA Graph's kernel node; false when S and IO are not
  /// those the kernel was built for.
  template <class S, class IO>
  bool launch_config(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape,
                     KernelLaunch& out) const;

  /// Where it came from and how long it took (CompiledLibrary::description).
  const CompiledLibrary& library() const { return *library_; }
  /// How it was built.
  const BlockBuild& build() const { return build_; }

 private:
  SpecializedBlockKernel() = default;

  template <class S, class IO>
  std::size_t shared_bytes(const ModelView<S>& model, const BatchPointers<IO>& batch, const BlockShape& shape) const;

  std::unique_ptr<CompiledLibrary> library_;
  KernelScalars scalars_ = KernelScalars::kF64;
  BlockBuild build_;
};

}  // namespace rbdgrad::cuda
