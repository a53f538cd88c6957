// One entry of an exchange (Gauss-Jordan) step of the block kernel's inversion of M, in place
// (block_fused_state.hpp's row segments and block_entry_inversion.hpp's entries): one arithmetic
// for both, so that they give the same bits.
#pragma once

#include "spatial.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// Entry (i, j) after the step on pivot pv: a_ij its value before, a_ip and a_pj the pivot
// column's and row's entries (the step's snapshots), r the pivot's reciprocal.
template <class S>
RBDGRAD_HD S exchanged_entry(int i, int j, int pv, S a_ij, S a_ip, S a_pj, S r) {
  const S exchanged = a_ij - a_ip * r * a_pj;
  return i == pv ? (j == pv ? r : -a_pj * r) : (j == pv ? a_ip * r : exchanged);
}

// Keeps the pivot of joint pv and flags it in *failed when it is not positive (group_max: the
// core's order checks the last joint first, so the largest failing joint is the one reported).
template <class S>
RBDGRAD_HD void keep_pivot(S* pivots, std::uint32_t* failed, int pv, S pivot) {
  pivots[pv] = pivot;
  if (!(is_finite(pivot) && pivot > S(0))) group_max(failed, static_cast<std::uint32_t>(pv) + 1u);
}

}  // namespace rbdgrad::cuda
