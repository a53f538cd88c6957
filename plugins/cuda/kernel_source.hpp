// The robot-specific block kernel's source, generated when a model is loaded: the block kernel's
// device code (device/block_kernel_entry.hpp, embedded in the plugin) instantiated with the
// model's sizes as compile-time constants (FixedSizeModelView), for NVRTC.
#pragma once

#include <string>

#include "nvrtc_compiler.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::cuda {

/// The program for `model` in f32 (single) or f64, compiled for the GPU architecture sm_<arch>
/// (90 for compute capability 9.0).
NvrtcProgram block_kernel_program(const Model& model, bool single, int arch);

}  // namespace rbdgrad::cuda
