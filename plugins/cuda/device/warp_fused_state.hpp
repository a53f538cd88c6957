// One state of a batch on a segment of W lanes of a warp, lane i holding joint i: the
// forward-dynamics gradient of block_fused_state.hpp (the same requests, algorithms, checks and
// outputs) with each joint's values in registers instead of shared memory, and no barrier wider
// than a warp. Paper 000's Algorithm 4 with paper 002's parallel prefix operations on the tree:
// - the placements and the sums over a joint's ancestors (world-frame velocities and
//   accelerations) by pointer jumping: ceil(log2(depth)) rounds of shuffles from the 2^r-th
//   ancestor, for any tree;
// - the sums over a subtree (composite inertias, forces) over the contiguous index range of the
//   subtree in depth-first order, through the state's rows of shared memory; where the model type
//   fixes the tree, each lane sums a share of the terms over the whole tree instead;
// - the body terms of the derivatives in compact form: a spatial inertia as mass, first moment and
//   a symmetric 3x3 (10 values, not 36), and the B operator of the core's derivatives as
//   B x = dI x + x x* h, where dI = v x* I - I v x is the inertia's rate (again a spatial inertia,
//   of zero mass) and h = I v the momentum: sums over a subtree stay in that form (26 values);
// - the columns of M, d tau/d qd and d tau/d q as products of the joints' rows of vectors, masked
//   by the tree (an entry is one product or another as its row is an ancestor or a descendant of
//   its column's joint), on the FP64 tensor cores (WarpLanes::tree_product);
// - M^-1 by exchange (Gauss-Jordan) steps, a column per lane, pivots in the order of the core's
//   factorization M = L^T D L, so that a state fails at the same joint for the same reason; where the model type fixes at most 8
//   joints, by a factorization M = U D U^T with the same pivots, in every lane (which reads M's
//   upper triangle only, so M's product keeps its up term only);
// - the products -M^-1 dc'/du through shared memory, on the FP64 tensor cores (WarpLanes::product);
// - the outputs staged in shared memory, a warp's states one after the other, and written by the
//   whole warp as whole lines.
// It computes in f64 (S = double: the GPUs whose f64 is fast, where f32 batches run in f64 as
// well); f32 batches elsewhere take the block kernel.
#pragma once

#include "block_fused_state.hpp"
#include "warp_lanes.hpp"

namespace rbdgrad::cuda {

// The largest model the warp kernel takes: half a warp per state. A whole warp per state (32
// joints: 255 registers with spills, columns as 32-step loops) made talos_reduced 1.2-2x slower
// than on the block kernel up to 1024 states and 1.07x at 4096, faster only from 16384
// (docs/benchmarks/cuda.md, run 40).
inline constexpr int kMaxWarpNv = 16;

// The segment width for nv joints: 8 or 16 lanes (0: too large for the warp kernel).
RBDGRAD_HD constexpr int warp_segment_width(int nv) { return nv <= 8 ? 8 : nv <= 16 ? 16 : 0; }

// Shared memory of a warp: its segments' regions one after the other, kScalars each, then
// kEarlyOutputs per segment for qdd and -M^-1 d tau/d qd on their way out early.
// A state's region: W rows of kRowStride (the subtree sums' terms, then the joint vectors that the
// products of rows read, six of them for d tau/d q's), M^-1, and the right factor of a product
// with M^-1, replaced by the product (W x W blocks, rows kBlockStride apart, 16-byte aligned for
// the products' paired stores). At the end the warp's regions stage its last outputs.
// The rows are read and written 16 bytes at a time (warp::load_pair): the row stride, 38 doubles,
// keeps them 16-byte aligned and puts rows 12 banks apart, so that a segment's lanes, each writing
// 16 bytes of its own row, cover the 32 banks once; in the tree products' joint order (tree_slot)
// a half warp's tensor-core loads (4 rows, 32 bytes of each) take their 2 wavefronts. The regions
// are padded so that the segments of a warp start 16 banks apart modulo 32: the two segments of
// a half warp then read and write the same places of their regions on different banks (without
// the padding, 48% of the kernel's shared-memory wavefronts were bank conflicts, ncu, run 49;
// 8 banks apart took twice the wavefronts of M^-1's columns, run 72). Where the padding holds a
// segment's W doubles (W = 8), it carries tau - c from the lanes to qdd's row products.
template <int W>
struct WarpShared {
  static constexpr int kSegments = 32 / W;
  static constexpr int kRowStride = 38;
  static constexpr int kMinv = W * kRowStride;
  // a product with M^-1: its right factor, replaced by the result (d tau/d qd's, read out into the
  // lanes, then d tau/d q's)
  static constexpr int kProduct = kMinv + W * kBlockStride<W>;
  static constexpr int kUsed = kProduct + W * kBlockStride<W>;
  // doubles (two banks each) between segments, modulo the 16 doubles of a row of banks
  static constexpr int kSegmentShift = 8;
  static constexpr int kScalars = kUsed + (kSegmentShift - kUsed % 16 + 16) % 16;
  static_assert(kScalars % 16 == kSegmentShift, "the segments' regions start 16 banks apart modulo 32");
  static_assert(kRowStride % 2 == 0 && kMinv % 2 == 0 && kProduct % 2 == 0 &&
                    kScalars % 2 == 0,
                "rows and W x W blocks start 16 bytes apart");
  static_assert(kRowStride % 4 == 2, "the tree products' joint order (tree_slot) spreads a half warp's rows over the banks");
  static_assert(W + 3 * W * W <= kScalars, "a state's region holds its last outputs");
  // qdd and -M^-1 d tau/d qd on their way out early
  static constexpr int kEarlyOutputs = W + W * W;
  // scalars of a warp of `segments` segments
  static RBDGRAD_HD constexpr int warp_scalars(int segments) { return segments * (kScalars + kEarlyOutputs); }
};

// The warp kernel takes what the block kernel takes, in f64, up to kMaxWarpNv joints.
template <class IO>
RBDGRAD_HD bool warp_kernel_supports(const BatchPointers<IO>& b, int nv) {
  return nv <= kMaxWarpNv && block_kernel_supports(b);
}

namespace warp {

// A spatial inertia [A, h x; -h x, m 1] about the world origin: mass, first moment, and A
// symmetric (xx xy xz yy yz zz). With m = 0 it also holds an inertia's rate.
template <class S>
struct Inertia {
  S m;
  S h[3];
  S A[6];
};
constexpr int kInertiaTerms = 10;

RBDGRAD_HD constexpr int sym(int r, int c) {
  return r == c ? (r == 0 ? 0 : r == 1 ? 3 : 5) : (r + c == 1 ? 1 : r + c == 2 ? 2 : 4);
}

// I x = [A w + h x v; m v - h x w] for x = [w; v]
template <class S>
RBDGRAD_HD Vec6<S> mul(const Inertia<S>& I, const Vec6<S>& x) {
  Vec6<S> out;
  for (int r = 0; r < 3; ++r) out.v[r] = I.A[sym(r, 0)] * x.v[0] + I.A[sym(r, 1)] * x.v[1] + I.A[sym(r, 2)] * x.v[2];
  cross3(I.h, x.v + 3, out.v, true);
  S hw[3];
  cross3(I.h, x.v, hw);
  for (int r = 0; r < 3; ++r) out.v[3 + r] = I.m * x.v[3 + r] - hw[r];
  return out;
}

// The rate of I moving with velocity v = [w; u]: v x* I - I v x = [w x A - A w x - (h u^T + u h^T)
// + 2 (u . h) 1, (w x h + m u) x; ..., 0]
template <class S>
RBDGRAD_HD Inertia<S> rate(const Inertia<S>& I, const Vec6<S>& v) {
  const S* w = v.v;
  const S* u = v.v + 3;
  Inertia<S> out;
  out.m = S(0);
  cross3(w, I.h, out.h);
  for (int r = 0; r < 3; ++r) out.h[r] += I.m * u[r];
  // P = w x A, column by column; the rate's A is P + P^T - ...
  S P[9];
  for (int c = 0; c < 3; ++c) {
    const S col[3] = {I.A[sym(0, c)], I.A[sym(1, c)], I.A[sym(2, c)]};
    S wc[3];
    cross3(w, col, wc);
    for (int r = 0; r < 3; ++r) P[3 * r + c] = wc[r];
  }
  const S uh = u[0] * I.h[0] + u[1] * I.h[1] + u[2] * I.h[2];
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) {
      S x = P[3 * r + c] + P[3 * c + r] - (I.h[r] * u[c] + u[r] * I.h[c]);
      if (r == c) x += S(2) * uh;
      out.A[sym(r, c)] = x;
    }
  return out;
}

template <class S>
RBDGRAD_HD void pack(const Inertia<S>& I, S* to) {
  to[0] = I.m;
  for (int k = 0; k < 3; ++k) to[1 + k] = I.h[k];
  for (int k = 0; k < 6; ++k) to[4 + k] = I.A[k];
}
template <class S>
RBDGRAD_HD Inertia<S> unpack(const S* from) {
  Inertia<S> I;
  I.m = from[0];
  for (int k = 0; k < 3; ++k) I.h[k] = from[1 + k];
  for (int k = 0; k < 6; ++k) I.A[k] = from[4 + k];
  return I;
}


// The 2^r-th ancestor of each lane's joint (-1 past the root), r < kMaxRounds.
constexpr int kMaxRounds = 5;
struct Jumps {
  int to[kMaxRounds];
  int rounds;  // 2^rounds >= the tree's depth
};
template <class Lanes>
RBDGRAD_HD Jumps jumps(int parent, int levels, const Lanes& g) {
  Jumps j;
  j.rounds = 0;
  while ((1 << j.rounds) < levels) ++j.rounds;
  j.to[0] = parent;
  for (int r = 0; r + 1 < kMaxRounds; ++r) {
    const int at = j.to[r];
    const int further = g.shfl(at, at < 0 ? g.lane : at);
    j.to[r + 1] = at < 0 ? -1 : further;
  }
  return j;
}
// The same from a model type that fixes the tree (FixedTree<Model>::known): no shuffles
template <class Model>
RBDGRAD_HD Jumps tree_jumps(const Model& m, int parent, int levels) {
  Jumps j;
  j.rounds = 0;
  while ((1 << j.rounds) < levels) ++j.rounds;
  j.to[0] = parent;
  for (int r = 0; r + 1 < kMaxRounds; ++r) {
    int at = j.to[r];
    if (r + 1 < j.rounds)
      for (int s = 0; s < (1 << r); ++s) at = at < 0 ? -1 : FixedTree<Model>::parent(m, at);
    else
      at = -1;  // no round reads it
    j.to[r + 1] = at;
  }
  return j;
}

// x over the joint and its ancestors, by pointer jumping: after round r a lane holds the sum over
// its joint and the 2^(r+1) - 1 joints above it
template <class S, int K, class Lanes>
RBDGRAD_HD void ancestor_sum(S (&x)[K], const Jumps& j, const Lanes& g) {
  for (int r = 0; r < kMaxRounds; ++r) {
    if (r >= j.rounds) break;
    const int at = j.to[r];
    S far[K];
    for (int k = 0; k < K; ++k) far[k] = g.shfl(x[k], at < 0 ? g.lane : at);
    if (at >= 0)
      for (int k = 0; k < K; ++k) x[k] += far[k];
  }
}
template <class S, class Lanes>
RBDGRAD_HD void ancestor_sum(Vec6<S>& x, const Jumps& j, const Lanes& g) {
  ancestor_sum(x.v, j, g);
}

// Pairs of values to and from shared memory (16-byte aligned): on the GPU one 16-byte access
// per pair, half the instructions of one per value. The warp kernel computes in f64.
template <class S>
RBDGRAD_HD void store_pair(S* to, S a, S b) {
#if defined(__CUDA_ARCH__)
  static_assert(sizeof(S) == sizeof(double), "pairs of doubles");
  *reinterpret_cast<double2*>(to) = make_double2(a, b);
#else
  to[0] = a;
  to[1] = b;
#endif
}
template <class S>
RBDGRAD_HD void load_pair(const S* from, S& a, S& b) {
#if defined(__CUDA_ARCH__)
  static_assert(sizeof(S) == sizeof(double), "pairs of doubles");
  const double2 v = *reinterpret_cast<const double2*>(from);
  a = v.x;
  b = v.y;
#else
  a = from[0];
  b = from[1];
#endif
}

// x over the joint's subtree [i, end) through the state's rows (stride `stride`, x at `rows`,
// both even: 16-byte pairs). Each lane writes its own terms; then
// - where the model type fixes the tree (Topology::known, kN joints), by terms: lane l takes the
//   pairs l + W p (p < kPairs, those below K / 2) of every joint's row into registers, adds each
//   joint's into its parent's from the leaves up (the tree as constants), writes back those of the
//   joints with descendants, and each lane reads its own row. Against every lane reading every row
//   of the state (one address a segment, keeping its descendants'), for iiwa14's K = 32: 30 reads
//   of 16 bytes and 24 additions a lane for 96 and 192 (runs 75 and 76: the kernel 9% faster);
// - otherwise each lane adds its descendants' rows in index order.
template <int W, int kN, class Topology, class S, int K, class Lanes, class Model>
RBDGRAD_HD void subtree_sum(S (&x)[K], S* rows, int stride, int i, int end, const Model& m, const Lanes& g) {
  static_assert(K % 2 == 0, "the terms go in pairs");
  for (int k = 0; k < K; k += 2) store_pair(rows + i * stride + k, x[k], x[k + 1]);
  g.sync();
  if constexpr (Topology::known) {
    constexpr int kPairs = (K / 2 + W - 1) / W;
    const auto mine = [&](int p) { return g.lane + W * p < K / 2; };
    const auto at = [&](int j, int p) { return rows + j * stride + 2 * (g.lane + W * p); };
    S t[kN][2 * kPairs] = {};
    for (int j = 0; j < kN; ++j)
      for (int p = 0; p < kPairs; ++p)
        if (mine(p)) load_pair(at(j, p), t[j][2 * p], t[j][2 * p + 1]);
    for (int j = kN - 1; j > 0; --j) {
      const int parent = Topology::parent(m, j);
      if (parent >= 0)
        for (int k = 0; k < 2 * kPairs; ++k) t[parent][k] += t[j][k];
    }
    // a lane writes back only what it read: no barrier between
    for (int j = 0; j < kN; ++j) {
      if (Topology::subtree_end(m, j) == j + 1) continue;  // a leaf's row is its sum
      for (int p = 0; p < kPairs; ++p)
        if (mine(p)) store_pair(at(j, p), t[j][2 * p], t[j][2 * p + 1]);
    }
    g.sync();
    // a lane's own row, which only it writes next: no barrier after
    for (int k = 0; k < K; k += 2) load_pair(rows + i * stride + k, x[k], x[k + 1]);
  } else {
    for (int j = i + 1; j < end; ++j)
      for (int k = 0; k < K; k += 2) {
        S a, b;
        load_pair(rows + j * stride + k, a, b);
        x[k] += a;
        x[k + 1] += b;
      }
    g.sync();
  }
}

// Column i of M^-1 (x, zero past kN) for a model of kN <= 8 joints, in every lane from the whole of
// M (kN x kN in shared memory, rows and columns in tree_slot order, rows `stride` apart, 16-byte
// aligned): M = U D U^T with U unit upper triangular, its pivots from the last joint to the first
// as the exchange steps' (pivot k the same Schur complement, so that a state fails at the same
// joint for the same reason), then U D U^T x = e_i by two triangular solves. Its upper triangle
// read by every lane in 16-byte pairs (iiwa14: 20 reads) where the exchange steps took kN^2
// shuffles of doubles (49) and kN^2 updates with selects (run 76: the kernel 2% faster).
template <int kN, int W, class S>
RBDGRAD_HD void minv_column_by_factors(const S* M, int stride, int i, S (&x)[W], std::uint32_t& status) {
  static_assert(kN <= 8 && W == 8, "a model on 8 lanes");
  S A[kN][kN] = {};  // M's upper triangle, then U's above the diagonal and D^-1 on it
  for (int a = 0; a < kN; ++a)
    for (int m = 0; m < 4; ++m) {
      const int j0 = slot_joint(2 * m), j1 = slot_joint(2 * m + 1);
      const bool in0 = a <= j0 && j0 < kN, in1 = a <= j1 && j1 < kN;
      if (!in0 && !in1) continue;
      S v0, v1;
      load_pair(M + tree_slot(a) * stride + 2 * m, v0, v1);
      if (in0) A[a][j0] = v0;
      if (in1) A[a][j1] = v1;
    }
  for (int k = kN - 1; k >= 0; --k) {
    const S d = A[k][k];
    // the first bad pivot in pivot order names the state's failure
    if (status == 0 && !is_finite(d)) status = state_status(Reason::kMassNotFinite, Algorithm::kNone, k);
    else if (status == 0 && !(d > S(0))) status = state_status(Reason::kMassNotPositive, Algorithm::kNone, k);
    const S rp = reciprocal(d);
    for (int a = 0; a < k; ++a) {
      const S u = A[a][k] * rp;
      for (int b = a; b < k; ++b) A[a][b] -= u * A[b][k];
      A[a][k] = u;
    }
    A[k][k] = rp;
  }
  // U y = e_i, then U^T x = D^-1 y
  S y[kN];
  for (int k = kN - 1; k >= 0; --k) {
    S v = k == i ? S(1) : S(0);
    for (int j = k + 1; j < kN; ++j) v -= A[k][j] * y[j];
    y[k] = v;
  }
  for (int k = 0; k < kN; ++k) {
    S v = y[k] * A[k][k];
    for (int j = 0; j < k; ++j) v -= A[j][k] * x[j];
    x[k] = v;
  }
  for (int k = kN; k < W; ++k) x[k] = S(0);
}

template <class S>
RBDGRAD_HD void store(S* to, const Vec6<S>& x) {
  for (int k = 0; k < 6; k += 2) store_pair(to + k, x.v[k], x.v[k + 1]);
}

// where each joint vector sits in a row: what the products of rows read (WarpLanes::tree_product).
// The places are reused: at k2Alpha f_qdd's subtree sum, then Dq (kDq); at kE beta (kBeta). The
// down terms of d tau/d qd and d tau/d q are one term of twelve each, [Ic S, Bc^T S] . [2 alpha, S]
// and . [beta, alpha], so those pairs sit side by side: three tensor-core steps where two terms
// of six took four (WarpLanes::tree_product).
enum Column : int {
  k2Alpha = 0, kFqdd = 0, kDq = 0,
  kAxis = 6, kIcS = 12, kBcTS = 18,
  kE = 24, kBeta = 24, kAlpha = 30
};
static_assert(kAxis == k2Alpha + 6 && kAlpha == kBeta + 6 && kBcTS == kIcS + 6, "the twelve-value terms' halves");

}  // namespace warp

// Computes `state` of b (warp_kernel_supports(b, m.nv)) on the segment g (W lanes, m.nv <= W) and
// writes its outputs and status; an inactive segment (past the end of the batch) computes `state`
// and writes nothing. sh: the state's region of its warp's shared memory (WarpShared<W>).
// kStages as in block_evaluate_state. early_outputs: qdd and d qdd/d qd written before d tau/d q
// is computed (the same for every segment of a warp).
// Model: ModelView<S>, or a FixedSizeModelView of it (the kernel compiled for one robot: the
// joint count and the tree's depth are constants, so that the loops over joints and the pointer
// jumping's rounds have fixed trip counts and the output offsets are constant multiples).
template <int W, class S, class IO, int kStages, class Lanes, class Model>
RBDGRAD_HD void warp_evaluate_state(const Model& m, S* sh, const BatchPointers<IO>& b, std::uint64_t state,
                                    bool active, bool early_outputs, const Lanes& g) {
  using warp::Column;
  using warp::Inertia;
  constexpr int kFixedNv = FixedSizes<Model>::nv;
  static_assert(kFixedNv <= W, "a segment holds every joint");
  // the rows that can hold values (ancestor masks, exchange steps): the joints where their count
  // is fixed (the rest of the W rows are zero and skipped), else all W
  constexpr int kRows = kFixedNv > 0 ? kFixedNv : W;
  const int n = kFixedNv > 0 ? kFixedNv : m.nv, i = g.lane;
  const int levels = FixedSizes<Model>::levels > 0 ? FixedSizes<Model>::levels : m.levels;
  const bool joint = i < n;
  const std::uint64_t vec = static_cast<std::uint64_t>(n), mat = vec * vec;
  constexpr bool kFixed = kStages != block_stages::kPerBatch;
  const bool want_dq = kFixed ? (kStages & block_stages::kDq) != 0 : (b.outputs & kOutputDqddDq) != 0;
  const bool want_dqd = kFixed ? (kStages & block_stages::kDqd) != 0 : (b.outputs & kOutputDqddDqd) != 0;
  const bool minv_supplied = kFixed ? (kStages & block_stages::kMinvSupplied) != 0 : b.minv != nullptr;
  constexpr int kStride = WarpShared<W>::kRowStride;
  constexpr int kBlock = kBlockStride<W>;
  S* const rows = sh;
  S* const minv_rows = sh + WarpShared<W>::kMinv;

  // the inputs, then the robot's constants (their loads overlap)
  S q = S(0), qd = S(0), u = S(0);
  if (joint) {
    q = static_cast<S>(b.q[state * vec + i]);
    qd = static_cast<S>(b.qd[state * vec + i]);
    u = static_cast<S>(b.u[state * vec + i]);
  }
  using Topology = FixedTree<Model>;  // the tree where the model type fixes it
  const int parent = joint ? Topology::parent(m, i) : -1;
  const int end = joint ? Topology::subtree_end(m, i) : i + 1;
  const warp::Jumps jumps = Topology::known ? warp::tree_jumps(m, parent, levels) : warp::jumps(parent, levels, g);
  // ancestors-or-self of this joint (bit r: joint r), the up rows of its columns
  unsigned ancestors = 0;
  for (int r = 0; r < kRows; ++r) {
    const int end_r = Topology::known ? Topology::subtree_end(m, r) : g.shfl(end, r);
    if (r <= i && i < end_r) ancestors |= 1u << r;
  }

  g.stamp();  // inputs and constants
  // the joint transform in the parent frame, then in the world by pointer jumping
  S R[9], p[3];
  for (int e = 0; e < 9; ++e) R[e] = joint ? m.joint_rotation[9 * i + e] : S(e % 4 == 0 ? 1 : 0);
  for (int r = 0; r < 3; ++r) p[r] = joint ? m.joint_translation[3 * i + r] : S(0);
  const bool prismatic = joint && m.prismatic[i];
  if (!prismatic) {
    S s, c;
#if defined(__CUDA_ARCH__)
    sincos(q, &s, &c);  // one argument reduction for both
#else
    s = std::sin(q);
    c = std::cos(q);
#endif
    // R0 * Rz(q): only the first two columns mix
    for (int r = 0; r < 3; ++r) {
      const S x = R[3 * r], y = R[3 * r + 1];
      R[3 * r] = c * x + s * y;
      R[3 * r + 1] = c * y - s * x;
    }
  } else {
    for (int r = 0; r < 3; ++r) p[r] += q * R[3 * r + 2];
  }
  for (int round = 0; round < warp::kMaxRounds; ++round) {
    if (round >= jumps.rounds) break;
    const int at = jumps.to[round];
    const int from = at < 0 ? i : at;
    // the ancestor's rotation by its first two columns (the third their cross product: a third
    // fewer shuffles)
    S Ra[9], pa[3];
    for (int r = 0; r < 3; ++r) {
      Ra[3 * r] = g.shfl(R[3 * r], from);
      Ra[3 * r + 1] = g.shfl(R[3 * r + 1], from);
      pa[r] = g.shfl(p[r], from);
    }
    for (int r = 0; r < 3; ++r) {
      const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
      Ra[3 * r + 2] = Ra[3 * r1] * Ra[3 * r2 + 1] - Ra[3 * r2] * Ra[3 * r1 + 1];
    }
    if (at >= 0) {
      S Rn[9], pn[3];
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) Rn[3 * r + c] = Ra[3 * r] * R[c] + Ra[3 * r + 1] * R[3 + c] + Ra[3 * r + 2] * R[6 + c];
        pn[r] = Ra[3 * r] * p[0] + Ra[3 * r + 1] * p[1] + Ra[3 * r + 2] * p[2] + pa[r];
      }
      for (int e = 0; e < 9; ++e) R[e] = Rn[e];
      for (int r = 0; r < 3; ++r) p[r] = pn[r];
    }
  }

  g.stamp();  // placements
  // the axis, the body's inertia about the world origin, the external force in the world
  Vec6<S> axis;
  {
    const S z[3] = {R[2], R[5], R[8]};
    if (!prismatic) {
      for (int r = 0; r < 3; ++r) axis.v[r] = z[r];
      cross3(p, z, axis.v + 3);
    } else {
      for (int r = 0; r < 3; ++r) {
        axis.v[r] = S(0);
        axis.v[3 + r] = z[r];
      }
    }
  }
  Inertia<S> I;
  {
    const S mass = joint ? m.mass[i] : S(0);
    S com[3], Ic[9];
    for (int r = 0; r < 3; ++r) com[r] = joint ? m.com[3 * i + r] : S(0);
    for (int e = 0; e < 9; ++e) Ic[e] = joint ? m.inertia_com[9 * i + e] : S(0);
    S co[3];
    for (int r = 0; r < 3; ++r) co[r] = R[3 * r] * com[0] + R[3 * r + 1] * com[1] + R[3 * r + 2] * com[2] + p[r];
    S RIc[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) RIc[3 * r + c] = R[3 * r] * Ic[c] + R[3 * r + 1] * Ic[3 + c] + R[3 * r + 2] * Ic[6 + c];
    const S co2 = co[0] * co[0] + co[1] * co[1] + co[2] * co[2];
    I.m = mass;
    for (int r = 0; r < 3; ++r) I.h[r] = mass * co[r];
    for (int r = 0; r < 3; ++r)
      for (int c = r; c < 3; ++c) {
        const S Icw = RIc[3 * r] * R[3 * c] + RIc[3 * r + 1] * R[3 * c + 1] + RIc[3 * r + 2] * R[3 * c + 2];
        I.A[warp::sym(r, c)] = Icw + mass * ((r == c ? co2 : S(0)) - co[r] * co[c]);
      }
  }
  Vec6<S> f_ext{};
  const IO* fext = b.fext ? b.fext + state * 6 * vec : nullptr;
  if (fext && joint) {
    // [moment about the link origin; force] in the URDF link frame -> world axes, world origin
    const S* lr = m.link_rotation + 9 * i;
    S Rl[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Rl[3 * r + c] = R[3 * r] * lr[c] + R[3 * r + 1] * lr[3 + c] + R[3 * r + 2] * lr[6 + c];
    S fl[6];
    for (int k = 0; k < 6; ++k) fl[k] = static_cast<S>(fext[6 * i + k]);
    for (int r = 0; r < 3; ++r) {
      f_ext.v[r] = Rl[3 * r] * fl[0] + Rl[3 * r + 1] * fl[1] + Rl[3 * r + 2] * fl[2];
      f_ext.v[3 + r] = Rl[3 * r] * fl[3] + Rl[3 * r + 1] * fl[4] + Rl[3 * r + 2] * fl[5];
    }
    cross3(p, f_ext.v + 3, f_ext.v, true);
  }

  g.stamp();  // axes, inertias, external forces
  // velocities, alpha = v_parent x S, momenta; accelerations with qdd = 0; body forces
  const Vec6<S> gravity{{S(0), S(0), S(0), -m.gravity[0], -m.gravity[1], -m.gravity[2]}};
  Vec6<S> v = scaled(axis, qd);
  warp::ancestor_sum(v, jumps, g);
  Vec6<S> v_parent;
  for (int k = 0; k < 6; ++k) v_parent.v[k] = g.shfl(v.v[k], parent < 0 ? i : parent);
  if (parent < 0) v_parent = Vec6<S>{};
  const Vec6<S> alpha = cross_motion(v_parent, axis);
  const Vec6<S> mom = warp::mul(I, v);
  Vec6<S> a = scaled(alpha, qd);
  warp::ancestor_sum(a, jumps, g);
  a = add(a, gravity);
  const Vec6<S> f = sub(add(warp::mul(I, a), cross_force(v, mom)), f_ext);

  g.stamp();  // velocities, accelerations, forces
  // subtree sums: composite inertia, its rate, momentum and force
  Inertia<S> Ic, dIc;
  Vec6<S> momc, F;
  {
    constexpr int kTerms = 2 * warp::kInertiaTerms + 12;
    S terms[kTerms];
    warp::pack(I, terms);
    warp::pack(warp::rate(I, v), terms + warp::kInertiaTerms);
    for (int k = 0; k < 6; ++k) {
      terms[2 * warp::kInertiaTerms + k] = mom.v[k];
      terms[2 * warp::kInertiaTerms + 6 + k] = f.v[k];
    }
    warp::subtree_sum<W, kFixedNv, Topology>(terms, rows, kStride, i, end, m, g);
    Ic = warp::unpack(terms);
    dIc = warp::unpack(terms + warp::kInertiaTerms);
    for (int k = 0; k < 6; ++k) {
      momc.v[k] = terms[2 * warp::kInertiaTerms + k];
      F.v[k] = terms[2 * warp::kInertiaTerms + 6 + k];
    }
  }
  g.stamp();  // subtree sums
  // c = tau(qdd = 0) = S . F; Ic S; Bc^T S = dIc S - S x* hc; E = 2 Ic alpha + Bc S
  const S c_joint = dot(axis, F);
  const Vec6<S> Ic_S = warp::mul(Ic, axis);
  const Vec6<S> dIc_S = warp::mul(dIc, axis);
  const Vec6<S> S_x_momc = cross_force(axis, momc);
  const Vec6<S> Bc_t_S = sub(dIc_S, S_x_momc);
  S* const row = rows + i * kStride;
  warp::store(row + Column::kAxis, axis);
  warp::store(row + Column::kIcS, Ic_S);
  warp::store(row + Column::kBcTS, Bc_t_S);
  if (want_dqd) {
    warp::store(row + Column::kE, add(scaled(warp::mul(Ic, alpha), S(2)), add(dIc_S, S_x_momc)));
    warp::store(row + Column::k2Alpha, scaled(alpha, S(2)));
  }
  // the columns of M, d tau/d qd and d tau/d q: row r of column i from the pair (r, i) of the block
  // kernel, r an ancestor-or-self ("up") or a strict descendant ("down") of joint i, else zero
  TreeRows keep;
  if (joint) {
    keep.up = ancestors;
    keep.down = ((1u << end) - 1u) & ~((2u << i) - 1u);
  }
  const auto tree = g.tree(keep);

  g.stamp();  // joint vectors
  // M: up S_r . Ic_S, down Ic_S_r . S (into M^-1's place; the exchange steps read this lane's column
  // back); d tau/d qd:
  // up S_r . E, down Ic_S_r . 2 alpha + Bc^T_S_r . S (into the right factor of its product with
  // M^-1)
  // M^-1 by a factorization in every lane (warp::minv_column_by_factors) where the model type fixes
  // at most 8 joints, else by exchange steps on the lanes' columns
  constexpr bool kFactorsInLanes = kFixedNv > 0 && kFixedNv <= 8;
  S col[W];
  if (!minv_supplied) {
    if constexpr (kFactorsInLanes) {
      // the factorization reads M's upper triangle only, whose rows are their column's ancestors or
      // in other branches (depth-first order), never its descendants: the down term is not needed
      g.tree_product(RowTerms<RowTerm<Column::kAxis, Column::kIcS>>{}, RowTerms<>{}, tree, rows, kStride, minv_rows);
    } else {
      g.tree_product(RowTerms<RowTerm<Column::kAxis, Column::kIcS>>{}, RowTerms<RowTerm<Column::kIcS, Column::kAxis>>{},
                     tree, rows, kStride, minv_rows);
      for (int r = 0; r < W; ++r) col[r] = minv_rows[tree_slot(r) * kBlock + tree_slot(i)];
    }
  }
  if (want_dqd)
    g.tree_product(RowTerms<RowTerm<Column::kAxis, Column::kE>>{}, typename PairedTerms<W, Column::kIcS, Column::k2Alpha>::type{},
                   tree, rows, kStride, sh + WarpShared<W>::kProduct);

  g.stamp();  // columns of M and d tau/d qd
  // M^-1: the caller's, or by a factorization in every lane, or by exchange steps on the columns
  // (leaves first, as the block kernel); the pivots are checked in pivot order
  std::uint32_t status = 0;
  if (minv_supplied) {
    // row i of the caller's M^-1 (for qdd's row; it goes to shared memory as that row)
    for (int r = 0; r < W; ++r) col[r] = joint && r < n ? static_cast<S>(b.minv[state * mat + i * vec + r]) : S(0);
  } else if constexpr (kFactorsInLanes) {
    warp::minv_column_by_factors<kFixedNv>(minv_rows, kBlock, i, col, status);
    g.sync();  // every lane's reads of M before M^-1 replaces it
  } else {
    for (int pv = W - 1; pv >= 0; --pv) {
      if (pv >= n) continue;
      S pivot_col[kRows];
      for (int r = 0; r < kRows; ++r) pivot_col[r] = g.shfl(col[r], pv);
      const S d = pivot_col[pv];
      // the first bad pivot in pivot order names the state's failure
      if (status == 0 && !is_finite(d)) status = state_status(Reason::kMassNotFinite, Algorithm::kNone, pv);
      else if (status == 0 && !(d > S(0))) status = state_status(Reason::kMassNotPositive, Algorithm::kNone, pv);
      const S rp = reciprocal(d);
      const S a_rp = col[pv] * rp;
      for (int r = 0; r < kRows; ++r) {
        S x;
        if (r == pv && i == pv) x = rp;
        else if (r == pv) x = -a_rp;
        else if (i == pv) x = pivot_col[r] * rp;
        else x = col[r] - pivot_col[r] * a_rp;
        col[r] = x;
      }
    }
  }
  // M^-1 with its columns in tree_slot order, as the products with it take it (WarpLanes::product)
  for (int r = 0; r < W; ++r)
    minv_rows[minv_supplied ? i * kBlock + tree_slot(r) : r * kBlock + tree_slot(i)] = col[r];
  // tau - c of every joint, through the region's spare doubles where a segment's fit there (a
  // 16-byte read for two joints where a shuffle took one)
  constexpr bool kDiffShared = WarpShared<W>::kScalars - WarpShared<W>::kUsed >= W;
  const S diff = u - c_joint;
  if constexpr (kDiffShared) sh[WarpShared<W>::kUsed + i] = diff;
  g.sync();
  g.stamp();  // M^-1
  // qdd = M^-1 (tau - c), row i: the caller's row, or the computed column i (M^-1 is symmetric;
  // the exchange steps' roundings aside, row and column are the same)
  S qdd = u;
  if (b.tau_input) {
    qdd = S(0);
    if constexpr (kDiffShared) {
      for (int j = 0; j < kRows; j += 2) {
        S d0, d1;
        warp::load_pair(sh + WarpShared<W>::kUsed + j, d0, d1);
        if (j < n) qdd += col[j] * d0;
        if (j + 1 < n) qdd += col[j + 1] * d1;
      }
    } else {
      for (int j = 0; j < kRows; ++j) {
        const S d_j = g.shfl(diff, j);
        if (j < n) qdd += col[j] * d_j;
      }
    }
  }

  // The outputs are staged in shared memory, a warp's states one after the other (n values or
  // n x n, no gaps), and written by the whole warp as whole lines (WarpLanes::write_warp); a value
  // that leaves IO's range or is not finite flags the state. With early_outputs, qdd and
  // -M^-1 d tau/d qd go out now, from the warp's area for them, so that their writes overlap
  // d tau/d q (large batches gain); otherwise everything goes at the end (host memory over PCIe in
  // the middle of the kernel costs a small batch's state more than it saves).
  bool bad = false;  // a value of this lane's not finite in IO
  const auto put = [&](S* to, S x) {
    const IO y = static_cast<IO>(x);
    bad = bad || !is_finite(y);
    *to = static_cast<S>(y);
  };
  // -M^-1 x, x in a product area: the product in place, this lane's column of it back
  const auto minv_product = [&](S* area, S(&out)[W]) {
    g.product(minv_rows, area);
    for (int r = 0; r < W; ++r) out[r] = -area[r * kBlock + tree_slot(i)];
  };
  S dqd_out[W] = {};
  if (want_dqd) minv_product(sh + WarpShared<W>::kProduct, dqd_out);
  const int n2 = n * n;
  // where (r, c) of this segment's state goes in a staging area of n x n per state
  const auto staged_at = [&](int r, int c) { return g.segment * n2 + r * n + c; };
  if (early_outputs) {
    S* const staged_qdd = g.warp_shared(sh) + Lanes::kSegments * g.shared_stride;  // after the regions
    S* const staged_dqd = staged_qdd + Lanes::kSegments * n;
    if (joint) put(staged_qdd + g.segment * n + i, qdd);
    if (want_dqd && joint)
      for (int r = 0; r < W; ++r)
        if (r < n) put(staged_dqd + staged_at(r, i), dqd_out[r]);
    g.sync();
    g.write_warp(staged_qdd, b.out[output_index(kOutputQdd)], n);
    if (want_dqd) g.write_warp(staged_dqd, b.out[output_index(kOutputDqddDqd)], n2);
  }

  g.stamp();  // qdd (with early_outputs, the first outputs)
  // d tau/d q: the motion due to qdd, beta, the subtree force with it, then the columns
  if (want_dq) {
    Vec6<S> a_qdd = scaled(axis, qdd);
    warp::ancestor_sum(a_qdd, jumps, g);
    const int from = parent < 0 ? i : parent;
    Vec6<S> a_parent;
    for (int k = 0; k < 6; ++k) a_parent.v[k] = g.shfl(a.v[k] + a_qdd.v[k], from);
    if (parent < 0) a_parent = gravity;
    Vec6<S> beta = cross_motion(a_parent, axis);
    if (parent >= 0) beta = add(beta, cross_motion(v_parent, alpha));
    S f_qdd[6];
    const Vec6<S> Ia = warp::mul(I, a_qdd);
    for (int k = 0; k < 6; ++k) f_qdd[k] = Ia.v[k];
    warp::subtree_sum<W, kFixedNv, Topology>(f_qdd, rows + Column::kFqdd, kStride, i, end, m, g);
    Vec6<S> F_total;
    for (int k = 0; k < 6; ++k) F_total.v[k] = F.v[k] + f_qdd[k];
    // Dq = S x* F + Ic beta + Bc alpha, Bc alpha = dIc alpha + alpha x* hc; the columns: up S_r . Dq,
    // down Ic_S_r . beta + Bc^T_S_r . alpha
    const Vec6<S> Dq = add(add(cross_force(axis, F_total), warp::mul(Ic, beta)),
                           add(warp::mul(dIc, alpha), cross_force(alpha, momc)));
    warp::store(row + Column::kDq, Dq);
    warp::store(row + Column::kBeta, beta);
    warp::store(row + Column::kAlpha, alpha);
    g.tree_product(RowTerms<RowTerm<Column::kAxis, Column::kDq>>{}, typename PairedTerms<W, Column::kIcS, Column::kBeta>::type{},
                   tree, rows, kStride, sh + WarpShared<W>::kProduct);
  }

  g.stamp();  // d tau/d q
  // the last outputs. Every segment done with its shared memory, the warp's regions (consecutive)
  // take them.
  S dq_out[W] = {};
  if (want_dq) minv_product(sh + WarpShared<W>::kProduct, dq_out);
  g.sync();
  S* const staged_dq = g.warp_shared(sh);
  S* const staged_minv = staged_dq + Lanes::kSegments * n2;
  S* const staged_dqd = staged_minv + Lanes::kSegments * n2;
  S* const staged_qdd = staged_dqd + Lanes::kSegments * n2;
  const bool want_minv = (b.outputs & kOutputMinv) != 0;
  if (joint) {
    if (!early_outputs) put(staged_qdd + g.segment * n + i, qdd);
    for (int r = 0; r < W; ++r) {
      if (r >= n) continue;
      if (want_dq) put(staged_dq + staged_at(r, i), dq_out[r]);
      // this lane's M^-1: column i computed, row i supplied
      if (want_minv) put(staged_minv + (minv_supplied ? staged_at(i, r) : staged_at(r, i)), col[r]);
      if (want_dqd && !early_outputs) put(staged_dqd + staged_at(r, i), dqd_out[r]);
    }
  }
  g.sync();
  if (want_dq) g.write_warp(staged_dq, b.out[output_index(kOutputDqddDq)], n2);
  if (want_minv) g.write_warp(staged_minv, b.out[output_index(kOutputMinv)], n2);
  if (!early_outputs) {
    g.write_warp(staged_qdd, b.out[output_index(kOutputQdd)], n);
    if (want_dqd) g.write_warp(staged_dqd, b.out[output_index(kOutputDqddDqd)], n2);
  }
  const bool any_bad = (g.or_warp(bad ? 1u << g.segment : 0u) >> g.segment & 1u) != 0;
  g.stamp();  // outputs
  if (i == 0 && active) {
    if (status == 0 && any_bad) status = not_finite<S>(Algorithm::kFdDerivatives);
    b.status[state] = status;
  }
}

}  // namespace rbdgrad::cuda
