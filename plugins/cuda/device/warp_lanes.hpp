// The lanes of one state in the warp kernel (warp_fused_state.hpp): a segment of W lanes of a warp,
// 32 / W states per warp, lane i holding joint i. Values move between the lanes of a segment by
// shuffles, and every lane of the warp runs every shuffle (the code has no divergent exchange).
// The tests run the same code on the host with one thread per lane (HostLanes in
// tests/plugins/cuda/warp_state_test.cpp), which gives these calls the same meaning.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

template <int W>
struct WarpLanes {
  static_assert(W == 8 || W == 16, "a segment is 8 or 16 lanes");
  static constexpr int kSegments = 32 / W;  // states per warp
  int lane = 0;    // joint index within the segment
  int segment = 0; // the segment's index within its warp
  // the warp's states are consecutive: segment s holds first_state + s; states_in_warp of them
  // are in the batch; their shared regions are shared_stride scalars apart
  std::uint64_t first_state = 0;
  int states_in_warp = 0;
  int shared_stride = 0;
#if defined(RBDGRAD_BLOCK_PASS_TIMING)
  // measurement builds only (bench/plugins/cuda_pass_timing.cpp): lane 0 of one segment writes
  // the SM clock at the end of each stage
  long long* clocks = nullptr;
  mutable int stage = 0;
  static constexpr int kMaxStageClocks = 32;
#endif

  // x of lane `from` of this segment (0 <= from < W)
  template <class T>
  RBDGRAD_HD T shfl(T x, int from) const {
#if defined(__CUDA_ARCH__)
    return __shfl_sync(0xffffffffu, x, from, W);
#else
    (void)from;
    return x;
#endif
  }
  // orders the warp's shared-memory writes before its later reads (the whole warp: its segments
  // stage their outputs in each other's regions)
  RBDGRAD_HD void sync() const {
#if defined(__CUDA_ARCH__)
    __syncwarp();
#endif
  }
  // The start of the warp's shared memory, given this segment's `region` (the segments' regions
  // are consecutive, shared_stride scalars each).
  template <class S>
  RBDGRAD_HD S* warp_shared(S* region) const {
    return region - segment * shared_stride;
  }
  // Writes the warp's states' `count` values each, staged one state after the other at `staged`
  // (shared memory), to out + first_state * count: consecutive lanes at consecutive addresses,
  // whole lines of memory rather than a segment's short rows. out == nullptr: nothing.
  template <class S, class IO>
  RBDGRAD_HD void write_warp(const S* staged, IO* out, int count) const {
#if defined(__CUDA_ARCH__)
    if (out == nullptr) return;
    IO* to = out + first_state * static_cast<std::uint64_t>(count);
    const int total = states_in_warp * count;
    for (int e = segment * W + lane; e < total; e += 32) to[e] = static_cast<IO>(staged[e]);
#else
    (void)staged;
    (void)out;
    (void)count;
#endif
  }
  // the end of a stage (measurement builds only)
  RBDGRAD_HD void stamp() const {
#if defined(__CUDA_ARCH__) && defined(RBDGRAD_BLOCK_PASS_TIMING)
    if (clocks != nullptr && lane == 0 && stage < kMaxStageClocks) clocks[stage++] = clock64();
#endif
  }
  // whether p holds on any lane of this segment
  RBDGRAD_HD bool any(bool p) const {
#if defined(__CUDA_ARCH__)
    const unsigned bits = __ballot_sync(0xffffffffu, p);
    const unsigned mask = ((1u << W) - 1u) << (segment * W);
    return (bits & mask) != 0;
#else
    return p;
#endif
  }
};

}  // namespace rbdgrad::cuda
