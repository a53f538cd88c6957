// The lanes of one state in the warp kernel (warp_fused_state.hpp): a segment of W lanes of a warp,
// 32 / W states per warp, lane i holding joint i. Values move between the lanes of a segment by
// shuffles, and every lane of the warp runs every shuffle (the code has no divergent exchange).
// The tests run the same code on the host with one thread per lane (HostLanes in
// tests/plugins/cuda/warp_state_test.cpp), which gives these calls the same meaning.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

// B = A B (W x W, row-major), lane `lane`'s column: its own column of B read and replaced, A only
// read. WarpLanes::product where there are no FP64 tensor cores, and the tests' host lanes.
template <int W, class S>
RBDGRAD_HD void lane_column_product(const S* A, S* B, int lane) {
  S column[W];
  for (int r = 0; r < W; ++r) {
    column[r] = S(0);
    for (int k = 0; k < W; ++k) column[r] += A[r * W + k] * B[k * W + lane];
  }
  for (int r = 0; r < W; ++r) B[r * W + lane] = column[r];
}

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
  // B = A B for the state of every segment of the warp, A and B W x W row-major in shared memory
  // at the same offsets in each segment's region (shared_stride scalars apart, both 16-byte
  // aligned). Every lane of the warp calls it, after writing its part of B, and reads the product
  // after it returns. On the GPU the warp's FP64 tensor-core steps (mma m8n8k4, written in PTX:
  // NVRTC has no mma.h) take each segment's product in turn, where a lane's column took W
  // dependent multiply-adds and W shared-memory reads for each of its W entries
  // (docs/benchmarks/cuda.md, runs 57 and 58).
  template <class S>
  RBDGRAD_HD void product(const S* A, S* B) const {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 800
    static_assert(sizeof(S) == sizeof(double), "the warp kernel computes in f64");
    constexpr int kTiles = W / 8;
    // the step's fragments (PTX ISA, mma.m8n8k4 .f64): lane t holds A(t / 4, t % 4),
    // B(t % 4, t / 4), and C(t / 4, 2 (t % 4)) with its right neighbour
    const int t = segment * W + lane, row = t >> 2, quad = t & 3;
    double c[kSegments][kTiles][kTiles][2];
    __syncwarp();
    // every segment's loads and steps first, then every store: the segments' products overlap
    for (int s = 0; s < kSegments; ++s) {
      const int shift = (s - segment) * shared_stride;
      for (int ti = 0; ti < kTiles; ++ti)
        for (int tj = 0; tj < kTiles; ++tj) {
          double d0 = 0.0, d1 = 0.0;
          for (int kc = 0; kc < W / 4; ++kc) {
            const double a = A[shift + (8 * ti + row) * W + 4 * kc + quad];
            const double b = B[shift + (4 * kc + quad) * W + 8 * tj + row];
            asm("mma.sync.aligned.m8n8k4.row.col.f64.f64.f64.f64 {%0, %1}, {%2}, {%3}, {%0, %1};"
                : "+d"(d0), "+d"(d1)
                : "d"(a), "d"(b));
          }
          c[s][ti][tj][0] = d0;
          c[s][ti][tj][1] = d1;
        }
    }
    __syncwarp();  // every lane's part of B read before the products replace it
    for (int s = 0; s < kSegments; ++s) {
      const int shift = (s - segment) * shared_stride;
      for (int ti = 0; ti < kTiles; ++ti)
        for (int tj = 0; tj < kTiles; ++tj) {
          double2* to = reinterpret_cast<double2*>(B + shift + (8 * ti + row) * W + 8 * tj + 2 * quad);
          *to = make_double2(c[s][ti][tj][0], c[s][ti][tj][1]);
        }
    }
    __syncwarp();
#else
    lane_column_product<W>(A, B, lane);  // a column per lane
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
