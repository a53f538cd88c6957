// The lanes of one state in the warp kernel (warp_fused_state.hpp): a segment of W lanes of a warp,
// 32 / W states per warp, lane i holding joint i. Values move between the lanes of a segment by
// shuffles, and every lane of the warp runs every shuffle (the code has no divergent exchange).
// The tests run the same code on the host with one thread per lane (HostLanes in
// tests/plugins/cuda/warp_state_test.cpp), which gives these calls the same meaning.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

// The W x W blocks in shared memory (M^-1, a product's factors) have their rows W + 4 doubles
// apart: a half warp's tensor-core loads (4 rows, 4 consecutive doubles of each) and 16-byte
// stores (4 rows, 8 doubles of each) then take each bank equally often, where rows W apart put
// two of the four rows on the same banks (ncu, run 72: twice the wavefronts of the products' loads).
template <int W>
inline constexpr int kBlockStride = W + 4;

// The order of the joints in the tree products: row and column m of a tile of 8 hold joint
// 2 (m % 4) + m / 4 of them (even joints, then odd), so that the four rows a half warp reads in
// a tensor-core step (m = 0..3 or 4..7), 38 doubles apart in order, are 4 doubles apart modulo
// the banks (0, 76, 152, 228 doubles: 0, 12, 8, 4 mod 16); in order they shared banks (ncu, run
// 72). tree_slot: where joint j is; slot_joint: the joint at slot m.
RBDGRAD_HD constexpr int slot_joint(int m) { return (m & ~7) | (m & 3) << 1 | (m >> 2 & 1); }
RBDGRAD_HD constexpr int tree_slot(int j) { return (j & ~7) | (j & 1) << 2 | (j >> 1 & 3); }

// B = A B (W x W, rows kBlockStride apart), column `column` of B read and replaced, A only read.
// WarpLanes::product where there are no FP64 tensor cores, and the tests' host lanes.
template <int W, class S>
RBDGRAD_HD void lane_column_product(const S* A, S* B, int column) {
  constexpr int P = kBlockStride<W>;
  S x[W];
  for (int r = 0; r < W; ++r) {
    x[r] = S(0);
    for (int k = 0; k < W; ++k) x[r] += A[r * P + k] * B[k * P + column];
  }
  for (int r = 0; r < W; ++r) B[r * P + column] = x[r];
}

// Products of the rows of a state's joints (each row a joint's vectors, `stride` scalars apart) that
// keep, in column n, the rows of n's ancestors-or-self ("up") and of its strict descendants
// ("down"), the rest zero: the columns of M, d tau/d qd and d tau/d q (warp_fused_state.hpp).
// A term: rows[r][A, A + L) . rows[n][B, B + L): a joint vector (L = 6), or two side by side (12).
template <int A, int B, int L = 6>
struct RowTerm {
  static constexpr int a = A, b = B, length = L;
};
template <class... Terms>
struct RowTerms {};

// rows[r][A, A + 12) . rows[n][B, B + 12) on segments of W lanes: one term of twelve on 8 lanes
// (three tensor-core steps where two terms of six take four), two of six on 16 (there the larger
// tiles of a term of twelve spilled registers)
template <int W, int A, int B>
struct PairedTerms {
  using type = RowTerms<RowTerm<A, B>, RowTerm<A + 6, B + 6>>;
};
template <int A, int B>
struct PairedTerms<8, A, B> {
  using type = RowTerms<RowTerm<A, B, 12>>;
};

// The rows a column keeps, bit r for row r.
struct TreeRows {
  unsigned up = 0, down = 0;
};

template <class Term, class S>
RBDGRAD_HD S row_term(const S* r, const S* n) {
  S x = r[Term::a] * n[Term::b];
  for (int k = 1; k < Term::length; ++k) x += r[Term::a + k] * n[Term::b + k];
  return x;
}

// out(r, lane) = up(r) ? sum of the Up terms : down(r) ? sum of the Down terms : 0 for r < W
// (out W x W, rows kBlockStride apart, rows and columns in tree_slot order): a lane's own column,
// where there are no FP64 tensor cores, and the tests' host lanes.
template <int W, class... Up, class... Down, class S>
RBDGRAD_HD void lane_tree_column(RowTerms<Up...>, RowTerms<Down...>, const S* rows, int stride, TreeRows keep, S* out,
                                 int lane) {
  const S* mine = rows + lane * stride;
  for (int r = 0; r < W; ++r) {
    const S* other = rows + r * stride;
    S x = S(0);
    if (keep.up >> r & 1u) x = (S(0) + ... + row_term<Up>(other, mine));
    else if (keep.down >> r & 1u) x = (S(0) + ... + row_term<Down>(other, mine));
    out[tree_slot(r) * kBlockStride<W> + tree_slot(lane)] = x;
  }
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
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 800
  // c += one term's A(row, k) B(k, column) over its k (lane quad's k of each step)
  template <class Term>
  static __device__ void mma_term(double (&c)[2], const double* a_row, const double* b_row, int quad) {
    for (int kc = 0; kc < (Term::length + 3) / 4; ++kc) {
      const int k = 4 * kc + quad;
      const bool in = k < Term::length;  // k past the term (6, 7 of six): zeros (a row's other values may be anything)
      const double a = in ? a_row[Term::a + k] : 0.0, b = in ? b_row[Term::b + k] : 0.0;
      asm("mma.sync.aligned.m8n8k4.row.col.f64.f64.f64.f64 {%0, %1}, {%2}, {%3}, {%0, %1};"
          : "+d"(c[0]), "+d"(c[1])
          : "d"(a), "d"(b));
    }
  }
#endif
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 800
  // Every segment's W x W result at `out` (rows kBlockStride apart, 16-byte aligned, the same
  // offset in each segment's region) from this lane's mma fragments c[s][ti][tj] (C(t / 4,
  // 2 (t % 4)) with its right neighbour of tile (ti, tj)), one 16-byte store each; then the warp's
  // barrier.
  __device__ void store_fragments(const double (&c)[kSegments][W / 8][W / 8][2], double* out) const {
    const int t = segment * W + lane, row = t >> 2, quad = t & 3;
    for (int s = 0; s < kSegments; ++s) {
      const int shift = (s - segment) * shared_stride;
      for (int ti = 0; ti < W / 8; ++ti)
        for (int tj = 0; tj < W / 8; ++tj) {
          double2* to = reinterpret_cast<double2*>(out + shift + (8 * ti + row) * kBlockStride<W> + 8 * tj + 2 * quad);
          *to = make_double2(c[s][ti][tj][0], c[s][ti][tj][1]);
        }
    }
    __syncwarp();
  }
#endif
  // the bitwise or of `bits` over the warp's lanes
  RBDGRAD_HD unsigned or_warp(unsigned bits) const {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 800
    return __reduce_or_sync(0xffffffffu, bits);
#elif defined(__CUDA_ARCH__)
    for (int d = 16; d > 0; d /= 2) bits |= __shfl_xor_sync(0xffffffffu, bits, d);
    return bits;
#else
    return bits;
#endif
  }
  // B = A B for the state of every segment of the warp, A and B W x W in shared memory (rows
  // kBlockStride apart) at the same offsets in each segment's region (shared_stride scalars
  // apart, both 16-byte aligned). Every lane of the warp calls it, after writing its part of B, and reads the product
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
            const double a = A[shift + (8 * ti + row) * kBlockStride<W> + 4 * kc + quad];
            const double b = B[shift + (4 * kc + quad) * kBlockStride<W> + 8 * tj + row];
            asm("mma.sync.aligned.m8n8k4.row.col.f64.f64.f64.f64 {%0, %1}, {%2}, {%3}, {%0, %1};"
                : "+d"(d0), "+d"(d1)
                : "d"(a), "d"(b));
          }
          c[s][ti][tj][0] = d0;
          c[s][ti][tj][1] = d1;
        }
    }
    __syncwarp();  // every lane's part of B read before the products replace it
    store_fragments(c, B);
#else
    lane_column_product<W>(A, B, tree_slot(lane));  // a column per lane (any order)
#endif
  }
  // The rows that the columns of this lane's tensor-core fragments keep (slot 8 tj + 2 (t % 4) + e
  // of a segment's W x W, t the lane in the warp), and those of its own column.
  struct Tree {
    TreeRows mine;
    unsigned up[W / 8][2], down[W / 8][2];
  };
  // keep: what this lane's joint's column keeps (the same for every segment: one robot)
  RBDGRAD_HD Tree tree(TreeRows keep) const {
    Tree tree;
    tree.mine = keep;
    const int quad = (segment * W + lane) & 3;
    for (int tj = 0; tj < W / 8; ++tj)
      for (int e = 0; e < 2; ++e) {
        tree.up[tj][e] = shfl(keep.up, slot_joint(8 * tj + 2 * quad + e));
        tree.down[tj][e] = shfl(keep.down, slot_joint(8 * tj + 2 * quad + e));
      }
    return tree;
  }
  // out(r, n) = up(r, n) ? sum of the Up terms : down(r, n) ? sum of the Down terms : 0 (W x W,
  // rows kBlockStride apart, rows and columns in tree_slot order, 16-byte aligned) for the state
  // of every segment of the warp, `rows` and `out` at
  // the same offsets in each segment's region. Every lane of the warp calls it after writing its
  // row; out is complete when it returns. On the GPU the FP64 tensor cores take each term in mma
  // steps of four k (six: 0..3, then 4..5 and two zeros; twelve: three steps), where a lane's own
  // column took its W rows' loads and dot products both ways (up and down) and kept one.
  template <class... Up, class... Down, class S>
  RBDGRAD_HD void tree_product(RowTerms<Up...> up, RowTerms<Down...> down, const Tree& tree, const S* rows,
                               int stride, S* out) const {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 800
    static_assert(sizeof(S) == sizeof(double), "the warp kernel computes in f64");
    (void)up;
    (void)down;
    constexpr int kTiles = W / 8;
    const int t = segment * W + lane, row = t >> 2, quad = t & 3;
    double c[kSegments][kTiles][kTiles][2];
    __syncwarp();  // the rows written
    for (int s = 0; s < kSegments; ++s) {
      const int shift = (s - segment) * shared_stride;
      for (int ti = 0; ti < kTiles; ++ti)
        for (int tj = 0; tj < kTiles; ++tj) {
          // A(r, k) = rows[r][a + k] and B(k, n) = rows[n][b + k]: lane t reads the joint at slot
          // t / 4 of both
          const double* a_row = rows + shift + slot_joint(8 * ti + row) * stride;
          const double* b_row = rows + shift + slot_joint(8 * tj + row) * stride;
          double u[2] = {0.0, 0.0}, d[2] = {0.0, 0.0};
          (mma_term<Up>(u, a_row, b_row, quad), ...);
          (mma_term<Down>(d, a_row, b_row, quad), ...);
          const int r = slot_joint(8 * ti + row);
          for (int e = 0; e < 2; ++e)
            c[s][ti][tj][e] = (tree.up[tj][e] >> r & 1u) ? u[e] : (tree.down[tj][e] >> r & 1u) ? d[e] : 0.0;
        }
    }
    store_fragments(c, out);
#else
    sync();
    lane_tree_column<W>(up, down, rows, stride, tree.mine, out, lane);
    sync();
#endif
  }
  // the end of a stage (measurement builds only)
  RBDGRAD_HD void stamp() const {
#if defined(__CUDA_ARCH__) && defined(RBDGRAD_BLOCK_PASS_TIMING)
    if (clocks != nullptr && lane == 0 && stage < kMaxStageClocks) clocks[stage++] = clock64();
#endif
  }
};

}  // namespace rbdgrad::cuda
