// The arithmetic of an exchange (Gauss-Jordan) step of the block kernel's inversion of M, in
// place, by row segments (block_fused_state.hpp): a row's factors, the pivot column's entries and
// the pivot kept and checked.
#pragma once

#include "spatial.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// Row i's factors in an exchange step on pivot pv: entry (i, j), j != pv, becomes u a_pj + s a_ij
// (a_ip and a_pj the pivot column's and row's entries, the step's snapshots, r the pivot's
// reciprocal): a_ij - (a_ip r) a_pj off the pivot row, -r a_pj on it (s = 0). One form for every
// row, so that a row's entries take a multiply and an add each and no selects; the pivot's column
// is the exception (pivot_column_entry).
template <class S>
struct ExchangeRow {
  S u, s;
};
template <class S>
RBDGRAD_HD ExchangeRow<S> exchange_row(int i, int pv, S a_ip, S r) {
  return i == pv ? ExchangeRow<S>{-r, S(0)} : ExchangeRow<S>{-(a_ip * r), S(1)};
}
// entry (i, pv) after the step: r on the pivot, a_ip r above and below it
template <class S>
RBDGRAD_HD S pivot_column_entry(int i, int pv, S a_ip, S r) {
  return i == pv ? r : a_ip * r;
}

// Keeps the pivot of joint pv and flags it in *failed when it is not positive (group_max: the
// core's order checks the last joint first, so the largest failing joint is the one reported).
template <class S>
RBDGRAD_HD void keep_pivot(S* pivots, std::uint32_t* failed, int pv, S pivot) {
  pivots[pv] = pivot;
  if (!(is_finite(pivot) && pivot > S(0))) group_max(failed, static_cast<std::uint32_t>(pv) + 1u);
}

}  // namespace rbdgrad::cuda
