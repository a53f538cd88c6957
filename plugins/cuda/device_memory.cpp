#include "device_memory.hpp"

#include <cuda_runtime_api.h>

#include <bit>

#include "cuda_device.hpp"

namespace rbdgrad::cuda {

namespace {
constexpr std::size_t kSmallestClass = 64 * 1024;
}  // namespace

Status Allocation::reserve(std::size_t bytes) {
  if (bytes <= capacity_) return Status::ok();
  return allocate(std::bit_ceil(bytes < kSmallestClass ? kSmallestClass : bytes));
}

Status Allocation::allocate_zeroed(std::size_t bytes) {
  if (Status s = allocate(bytes); !s) return s;
  return cuda_status(cudaMemset(data_, 0, bytes), "cudaMemset of the workspace");
}

Status Allocation::allocate(std::size_t bytes) {
  release();
  const cudaError_t e =
      kind_ == MemoryKind::kDevice ? cudaMalloc(&data_, bytes) : cudaHostAlloc(&data_, bytes, cudaHostAllocMapped);
  if (e != cudaSuccess) {
    data_ = nullptr;
    return cuda_status(e, (kind_ == MemoryKind::kDevice ? "cudaMalloc of " : "cudaHostAlloc of ") +
                              std::to_string(bytes) + " bytes");
  }
  capacity_ = bytes;
  device_address_ = data_;
  if (kind_ == MemoryKind::kPinnedHost) {
    if (Status s = cuda_status(cudaHostGetDevicePointer(&device_address_, data_, 0), "cudaHostGetDevicePointer"); !s) {
      release();
      return s;
    }
  }
  return Status::ok();
}

void Allocation::release() {
  if (data_ == nullptr) return;
  // errors here mean the context is gone already: nothing left to free
  if (kind_ == MemoryKind::kDevice) cudaFree(data_);
  else cudaFreeHost(data_);
  data_ = nullptr;
  device_address_ = nullptr;
  capacity_ = 0;
}

}  // namespace rbdgrad::cuda
