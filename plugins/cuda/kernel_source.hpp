// The robot-specific kernels' sources, generated when a model is loaded: the block kernel's and
// the warp kernel's device code (device/block_kernel_entry.hpp, device/warp_kernel_entry.hpp,
// embedded in the plugin) instantiated with the model's sizes as compile-time constants
// (FixedSizeModelView), for NVRTC.
#pragma once

#include <string>

#include "device/block_stages.hpp"
#include "nvrtc_compiler.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::cuda {

/// What a block kernel computes in, and the scalars of the batches it takes.
enum class KernelScalars {
  kF64,
  kF32,
  kF64ForF32,  // f32 batches computed in f64 (GPUs whose f64 is fast, cuda_instance.hpp)
};
const char* kernel_scalars_name(KernelScalars scalars);  // "f64", "f32", "f64 for f32"

/// "stages per batch", "stages fixed: d/dq, M^-1 computed": a kernel's block_stages, for logs.
std::string block_stages_text(int stages);

/// How the block kernel for a robot is built: compact (block_kernel_entry.hpp: the robot's scalar
/// constants in device memory, the matrices packed by the roots' blocks), a cap on its registers a
/// thread (register_cap.hpp; 0: none), lean: the compact kernel's lean working set
/// (block_workspace.hpp; ignored without compact), tree_chains: the lean build's M^-1 by the
/// tree's chains where they fit (device/block_tree_chains.hpp; ignored without lean), and
/// tree_columns: with them, M^-1's columns by the tree's blocks (device/block_tree_columns.hpp;
/// ignored without tree_chains; the plugin option block_tree_columns, off until a GPU times it).
struct BlockBuild {
  bool compact = false;
  int register_cap = 0;
  bool lean = false;
  bool tree_chains = false;
  bool tree_columns = false;
};

/// The program for `model` in `scalars`, compiled for the GPU architecture sm_<arch> (90 for
/// compute capability 9.0); `stages` a scene's fixed block_stages, or kPerBatch.
NvrtcProgram block_kernel_program(const Model& model, KernelScalars scalars, int arch,
                                  int stages = block_stages::kPerBatch, const BlockBuild& build = {});

/// The warp kernel's entry points for `model` (nv <= kMaxWarpNv) with its joint count and depth
/// fixed, for sm_<arch>: name_expressions[e] is WarpEntry e (warp_launch.hpp) for f64 batches, then with
/// f32_batches name_expressions[kWarpEntries + e] the same for f32 batches (computed in f64).
NvrtcProgram warp_kernel_program(const Model& model, bool f32_batches, int arch);

}  // namespace rbdgrad::cuda
