// Owned CUDA allocations: device memory and pinned (page-locked) host memory, which asynchronous
// copies need. Both grow by size class (powers of two), so that a stream of batches of similar
// sizes allocates a few times at most and never on the steady path.
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
  template <class T> T* as() const { return static_cast<T*>(data_); }
  std::size_t capacity() const { return capacity_; }

 private:
  Status allocate(std::size_t bytes);
  void release();

  MemoryKind kind_;
  void* data_ = nullptr;
  std::size_t capacity_ = 0;
};

}  // namespace rbdgrad::cuda
