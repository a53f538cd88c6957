// Run-time compilation with NVRTC, loaded with dlopen on first use: the plugin loads and runs its
// generic kernel on machines that have the CUDA driver but not NVRTC; only the robot-specific
// kernel (kernel_source.hpp) needs it.
#pragma once

#include <string>
#include <vector>

#include "embedded_headers.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

struct NvrtcProgram {
  std::string source;                   // the main file
  std::string name;                     // its name in messages
  std::vector<EmbeddedHeader> headers;  // what it may include, by name
  std::vector<std::string> options;     // e.g. "--gpu-architecture=sm_90"
  std::vector<std::string> name_expressions;  // the kernels (template instances) whose symbols are wanted
};

struct NvrtcOutput {
  std::string cubin;         // the device code, loadable with cudaLibraryLoadData
  std::vector<std::string> kernel_symbols;  // the mangled names of name_expressions, in their order
  std::string log;           // NVRTC's messages (warnings on success)
};

/// NVRTC's version ("13.0"), or an unavailable error saying why NVRTC cannot be loaded.
Status nvrtc_version(std::string& version);

/// Compiles `program` to a cubin. Errors: unavailable (no NVRTC), internal (the compilation
/// failed; the message holds NVRTC's log).
Status nvrtc_compile(const NvrtcProgram& program, NvrtcOutput& out);

}  // namespace rbdgrad::cuda
