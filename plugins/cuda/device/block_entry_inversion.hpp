// The block kernel's inversion of M by exchange steps (block_fused_state.hpp), each step's items
// the stored entries of the packed matrix instead of row segments: a warp's lanes take
// consecutive entries at consecutive addresses (no bank conflicts by construction), and the
// entries of a block whose steps are done leave no lanes idle in the others' (talos_reduced's
// torso: 400 entries, 12.5 warp iterations a step, where its 20 rows in segments of four take 4
// warps of 5 iterations). An entry's block, row and column come from the roots' blocks as
// compile-time constants (FixedSizeModelView's ROOT_BLOCKS, the lean build compiled for the
// robot). Each entry gets the same arithmetic as in the row segments, so the same bits; each
// pivot's reciprocal is computed once, by the thread of the pivot's entry in the step before (the
// first by the snapshots' pass), where the row segments compute it in every row's thread.
#pragma once

#include "block_workspace.hpp"
#include "exchange_step.hpp"
#include "model_view.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// The steps of the inversion in place in w.M (the packed matrices, kMatrixScalars of them), from
// the snapshots of the first step's pivot rows and columns (snapshot_row, snapshot_col: two
// buffers of n each, the first filled) and its pivots' reciprocals (w.pivot_reciprocals at each
// block's last joint): as block_fused_state.hpp's row segments, the pivots kept in w.pivots and
// the first that is not positive flagged in w.failed_pivot.
template <class S, unsigned long long kRootBlocks, int kMatrixScalars>
RBDGRAD_HD void block_invert_by_entries(const BlockWorkspace<S>& w, int n, S* snapshot_row, S* snapshot_col,
                                        int steps, const ThreadGroup& g) {
  using Blocks = RootBlocks<kRootBlocks>;
  static_assert(Blocks::count >= 1 && Blocks::offset(Blocks::count) == kMatrixScalars,
                "the roots' blocks fill the packed matrices");
  S* const inverse = w.M;
  S* const reciprocals = w.pivot_reciprocals;
  for (int step = 0; step < steps; ++step) {
    const S* const row = snapshot_row + (step & 1) * n;
    const S* const col = snapshot_col + (step & 1) * n;
    S* const next_row = snapshot_row + ((step + 1) & 1) * n;
    S* const next_col = snapshot_col + ((step + 1) & 1) * n;
    g.for_each(kMatrixScalars, [&](int e) {
      // the entry's block (the last one whose entries start at or before it), then its row and
      // column by a float reciprocal of the block's size (exact: e < 4096, sizes up to 64, as
      // block::Divider)
      int root = Blocks::root(0), size = Blocks::size(0), offset = 0;
      float inverse_size = 1.0f / static_cast<float>(Blocks::size(0));
      for (int b = 1; b < Blocks::count; ++b) {
        if (e >= Blocks::offset(b)) {
          root = Blocks::root(b);
          size = Blocks::size(b);
          offset = Blocks::offset(b);
          inverse_size = 1.0f / static_cast<float>(Blocks::size(b));
        }
      }
      if (step >= size) return;  // the block's steps are done
      const int local = e - offset;
      const int r = static_cast<int>((static_cast<float>(local) + 0.5f) * inverse_size);
      const int i = root + r, j = root + (local - r * size), pv = root + size - 1 - step;
      const S a_pj = row[j], a_ip = col[i], reciprocal = reciprocals[pv];
      const S x = exchanged_entry(i, j, pv, inverse[e], a_ip, a_pj, reciprocal);
      if (i == pv && j == pv) keep_pivot(w.pivots, w.failed_pivot, pv, row[pv]);
      inverse[e] = x;
      if (i == pv - 1) next_row[j] = x;
      if (j == pv - 1) {
        next_col[i] = x;
        // the next step's pivot
        if (i == pv - 1) reciprocals[pv - 1] = S(1) / x;
      }
    });
    g.sync();
  }
}

}  // namespace rbdgrad::cuda
