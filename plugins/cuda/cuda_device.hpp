// The CUDA runtime's errors as Status values, and the question every entry point asks first:
// is there a GPU (and this one)?
#pragma once

#include <cuda_runtime_api.h>

#include <string>

#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

/// ok for cudaSuccess, else "<what>: <CUDA's error string>": unavailable for a missing or broken
/// device or driver and for memory exhaustion, internal for anything else (a bug).
Status cuda_status(cudaError_t error, const std::string& what);

/// Whether device `device` can be used: unavailable "no CUDA device: cudaGetDeviceCount: <error>"
/// without a driver or GPU, "CUDA device 2 not present: 1 visible" for a wrong index.
Status check_device(int device);

}  // namespace rbdgrad::cuda
