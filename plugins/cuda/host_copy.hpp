// Host-side copies of a large batch, split over a few threads. A caller's pageable arrays go
// through the instance's pinned staging block by memcpy on the calling thread: talos_reduced f64
// at N = 16384 took 59 ms with pageable arrays (268 MB of outputs) against 6.5 ms with pinned
// ones (docs/benchmarks/cuda.md, scheduler.md), and one thread's memcpy is a fraction of the
// memory bandwidth. Below kParallelCopyMinBytes one memcpy per block is cheaper than threads.
#pragma once

#include <cstddef>
#include <span>

namespace rbdgrad::cuda {

struct HostCopy {
  void* to;
  const void* from;
  std::size_t bytes;
};

inline constexpr std::size_t kParallelCopyMinBytes = std::size_t{8} << 20;

/// Performs every copy (the blocks must not overlap). When they total at least
/// kParallelCopyMinBytes, the bytes are split into equal contiguous ranges over up to
/// `max_threads` threads (one about every 4 MiB), the calling thread taking the first range.
void copy_in_parallel(std::span<const HostCopy> copies, unsigned max_threads);

/// The thread count copy_in_parallel is given: the machine's cores, at most 8.
unsigned host_copy_threads();

}  // namespace rbdgrad::cuda
