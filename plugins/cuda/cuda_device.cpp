#include "cuda_device.hpp"

namespace rbdgrad::cuda {

Status cuda_status(cudaError_t error, const std::string& what) {
  if (error == cudaSuccess) return Status::ok();
  const std::string message = what + ": " + cudaGetErrorString(error);
  switch (error) {
    case cudaErrorMemoryAllocation:
    case cudaErrorNoDevice:
    case cudaErrorInsufficientDriver:
    case cudaErrorDevicesUnavailable:
    case cudaErrorInitializationError:
    case cudaErrorCudartUnloading:
      return unavailable(message);
    default:
      return Status(StatusCode::kInternal, message);
  }
}

Status check_device(int device) {
  int count = 0;
  if (const cudaError_t e = cudaGetDeviceCount(&count); e != cudaSuccess)
    return unavailable(std::string("no CUDA device: cudaGetDeviceCount: ") + cudaGetErrorString(e));
  if (count == 0) return unavailable("no CUDA device: cudaGetDeviceCount found none");
  if (device < 0 || device >= count)
    return unavailable("CUDA device " + std::to_string(device) + " not present: " + std::to_string(count) + " visible");
  return Status::ok();
}

}  // namespace rbdgrad::cuda
