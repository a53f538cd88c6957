// The threads that share one state in the block kernel (Algorithm 4 of paper 000): `size` threads
// of which this is `rank`. A pass over independent work items is for_each(); sync() separates
// passes that read what an earlier one wrote. Compiled as plain C++ (the host tests), one thread
// runs the whole group: for_each runs all items in order and sync() does nothing, which computes
// the same values, since no item of a pass reads what another item of the same pass writes.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_SHARED_TRACE) && !defined(__CUDA_ARCH__)
// Host tool builds only (bench/plugins/cuda_shared_wavefronts.cpp): told which of the group's
// threads runs each item (as the GPU spreads them) and of each sync, so that the kernel's
// shared-memory accesses can be grouped into a warp's instructions.
struct SharedTraceThreads {
  virtual void thread(int rank) = 0;
  virtual void sync(bool warp) = 0;

 protected:
  ~SharedTraceThreads() = default;
};
#endif

struct ThreadGroup {
  int rank = 0;
  int size = 1;
  // the group's threads sync through __syncwarp when the groups of the block tile warps (one
  // warp per state or several states per warp), else through __syncthreads (every group of the
  // block runs the same passes, so all reach each sync)
  bool warp_sync = false;
  // host tests only: run each pass's items in reverse order, which changes the results if an item
  // reads what another item of the same pass writes
  bool reverse = false;
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  // measurement builds only (bench/plugins/cuda_pass_timing.cpp): rank 0 of one group writes the
  // SM clock after each sync, so the cost of every pass shows
  long long* clocks = nullptr;
  mutable int pass = 0;
#endif
#if defined(RBDGRAD_SHARED_TRACE) && !defined(__CUDA_ARCH__)
  SharedTraceThreads* trace = nullptr;
  int first_rank = 0;  // the block's thread that is this group's rank 0 (a split group's part)
#endif

  RBDGRAD_HD void sync() const {
#if defined(RBDGRAD_SHARED_TRACE) && !defined(__CUDA_ARCH__)
    if (trace != nullptr) trace->sync(warp_sync);
#endif
#if defined(__CUDA_ARCH__)
    if (warp_sync) __syncwarp();
    else __syncthreads();
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
    if (clocks != nullptr && rank == 0 && pass < kMaxPassClocks - 2) clocks[pass++] = clock64();
#endif
#endif
  }
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  static constexpr int kMaxPassClocks = 128;
#endif

  // f(item) for item in [0, count), spread over the group's threads
  template <class F>
  RBDGRAD_HD void for_each(int count, F&& f) const {
#if !defined(__CUDA_ARCH__)
    // the whole group's items, one after another: size only shapes the items (a pass may give
    // each thread a segment of a row)
    if (reverse) {
      for (int item = count - 1; item >= 0; --item) f(item);
    } else {
#if defined(RBDGRAD_SHARED_TRACE)
      // (one copy of the item's code: a site of it is one instruction of the warp)
#pragma GCC unroll 1
      for (int item = 0; item < count; ++item) {
        if (trace != nullptr) trace->thread(first_rank + item % size);
        f(item);
      }
#else
      for (int item = 0; item < count; ++item) f(item);
#endif
    }
#else
    for (int item = rank; item < count; item += size) f(item);
#endif
  }
};

// *at = max(*at, value) for the threads of a group that meet the same word (shared memory)
RBDGRAD_HD void group_max(std::uint32_t* at, std::uint32_t value) {
#if defined(__CUDA_ARCH__)
  atomicMax(at, value);
#else
  if (value > *at) *at = value;
#endif
}

}  // namespace rbdgrad::cuda
