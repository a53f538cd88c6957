// Owned CUDA allocations: device memory and pinned (page-locked) host memory, which asynchronous
// copies need and which is also mapped into the device's address space (a kernel can read and
// write it over PCIe without a copy: the small-batch path). Both grow by size class (powers of
// two), so that a stream of batches of similar sizes allocates a few times at most and never on
// the steady path.
#pragma once

#include <cstddef>

#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

enum class MemoryKind { kDevice, kPinnedHost };

class Allocation {
 public:
  explicit Allocation(MemoryKind kind) : kind_(kind) {}
  ~Allocation() { release(); }
  Allocation(const Allocation&) = delete;
  Allocation& operator=(const Allocation&) = delete;

  /// Makes room for at least `bytes` (contents are not kept): the next power of two, 64 KiB at least.
  /// Errors: the allocation failed (unavailable, with CUDA's message).
  Status reserve(std::size_t bytes);
  /// Exactly `bytes`, zero-filled (device memory only: the workspace).
  Status allocate_zeroed(std::size_t bytes);

  void* data() const { return data_; }
  /// Pinned host memory: the address kernels use for it (equal to data() with unified addressing).
  void* device_address() const { return device_address_; }
  template <class T> T* as() const { return static_cast<T*>(data_); }
  std::size_t capacity() const { return capacity_; }

 private:
  Status allocate(std::size_t bytes);
  void release();

  MemoryKind kind_;
  void* data_ = nullptr;
  void* device_address_ = nullptr;
  std::size_t capacity_ = 0;
};

}  // namespace rbdgrad::cuda
