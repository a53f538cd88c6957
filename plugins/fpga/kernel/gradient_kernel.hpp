// The FPGA kernel's computation, written as Vitis HLS C++ and compiled by g++ as its C simulation:
// the completely fused forward-dynamics gradient of paper 000 (section IV-C) for one state, in the
// scalar T (the project's Fixed<W, F> stands in for ap_fixed<W, W - F, AP_RND_INF, AP_SAT> outside
// synthesis; double gives the reference of the same algorithm).
//
// - RNEA in each body's own frame (Algorithm 1): the values stay of the size of the robot's
//   velocities and forces, which keeps most states within 32-bit fixed point (the core's
//   world-frame passes overflow Q16.16 more often, see tests/core/reference_accuracy_test.cpp).
// - Its gradient as Algorithm 5 orders it: every column j of dc/du (u = q and qd) in its own
//   datapath (the loops over columns are the ones HLS unrolls), the forward sweep of the
//   derivatives fused with the forward pass, and the structure written out rather than multiplied
//   by: a joint transform is a rotation and an offset (never a 6x6 product), and S has a single
//   nonzero (a joint turns or slides along its local z), so cross products with S are moves and
//   negations.
// - dqdd/du = -M^-1 dc/du with M^-1 from the host, as the paper's FPGA design takes it.
//
// Joint angles arrive as sin and cos (the host computes them: an FPGA would otherwise need a
// CORDIC core per joint). Every arithmetic operation of T saturates and flags an overflow
// (FixedOverflowScope in the caller), so an out-of-range state is never silently wrong.
//
// gradient_top.cpp is the top function around it (the AXI ports, a batch of states); the host
// drives it (host/fpga_instance.cpp) and host/latency_model.hpp counts its cycles.
#pragma once

#include <cstdint>
#include <type_traits>

#include "hls_support.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::fpga {

// The column sets of the gradient, as a scene asks for them: which datapaths run.
inline constexpr unsigned kColumnsDq = 1, kColumnsDqd = 2;

// The columns [begin, end) of dc/du (q then qd, n each) that `columns` selects: a contiguous range,
// so that the loops over them get shorter (fewer iterations of the unrolled datapaths on the card,
// less work in C simulation) instead of idling.
struct ColumnRange {
  int begin, end;
  ColumnRange(unsigned columns, int n)
      : begin((columns & kColumnsDq) ? 0 : n),
        end((columns & kColumnsDqd) ? 2 * n : ((columns & kColumnsDq) ? n : 0)) {}
};

// The columns fixed at compile time, passed where the functions below take `columns`: the kernel
// built for one column set, which never had the other set's datapaths (issue 8's "build without
// the stage"; the top function takes its columns at run time, from the mode word). The range
// becomes a constant and a column's kind (q or qd) a literal, so the code that only the other set
// runs is not generated. Same operations, in the same order, as with the same columns at run time.
template <unsigned kColumns>
using FixedColumns = std::integral_constant<unsigned, kColumns>;

namespace detail {
// whether column j (of the 2n, q then qd) is a d/dq column
template <class Columns>
constexpr bool is_q_column(Columns, int j, int n) {
  return j < n;
}
// with the columns fixed to one set, a literal
template <unsigned kColumns>
constexpr bool is_q_column(FixedColumns<kColumns>, int j, int n) {
  return kColumns == kColumnsDq ? true : (kColumns == kColumnsDqd ? false : j < n);
}
// whether column j is joint i's own d/dq column (j == i < n)
template <class Columns>
constexpr bool is_own_q_column(Columns, int j, int i) {
  return j == i;
}
// never with the d/dqd columns fixed alone
template <unsigned kColumns>
constexpr bool is_own_q_column(FixedColumns<kColumns>, int j, int i) {
  return kColumns != kColumnsDqd && j == i;
}
}  // namespace detail

// The robot as the kernel sees it (constants of the bitstream on hardware): topology, each joint's
// fixed transform from its parent's frame, and each body's spatial inertia in its own frame.
template <class T, int MaxNv>
struct RobotConstants {
  int nv = 0;
  int parent[MaxNv] = {};     // -1 for the world; parent[i] < i
  bool prismatic[MaxNv] = {};  // else revolute; about / along the joint frame's z
  T joint_rotation[MaxNv][9] = {};     // joint frame in the parent body frame, row-major (R0)
  T joint_translation[MaxNv][3] = {};  // joint frame origin in the parent body frame (p0)
  T inertia[MaxNv][36] = {};  // about the body origin, body axes, row-major 6x6
  T gravity[3] = {};          // world frame
};

// One state's working set (on-chip memory on hardware): per body 6-vectors, and per body and
// column of dc/du the derivative vectors.
template <class T, int MaxNv>
struct KernelState {
  T E[MaxNv][9];  // rotation from the parent frame to the body frame (row-major)
  T r[MaxNv][3];  // joint origin in the parent frame
  T v[MaxNv][6], a[MaxNv][6], f[MaxNv][6], h[MaxNv][6], Xv[MaxNv][6], Xa[MaxNv][6];
  T dv[MaxNv][2 * MaxNv][6], da[MaxNv][2 * MaxNv][6], df[MaxNv][2 * MaxNv][6];
  T dc[MaxNv][2 * MaxNv];  // rows: joints, columns: q then qd
};

namespace detail {

// x = E y for 3-vectors (row-major E)
template <class T>
void rotate(const T* E, const T* y, T* x) {
  for (int r = 0; r < 3; ++r) {
    RBDGRAD_HLS_PRAGMA(HLS UNROLL)
    x[r] = E[3 * r] * y[0] + E[3 * r + 1] * y[1] + E[3 * r + 2] * y[2];
  }
}
// x = E^T y
template <class T>
void rotate_back(const T* E, const T* y, T* x) {
  for (int c = 0; c < 3; ++c) {
    RBDGRAD_HLS_PRAGMA(HLS UNROLL)
    x[c] = E[c] * y[0] + E[3 + c] * y[1] + E[6 + c] * y[2];
  }
}
template <class T>
void cross(const T* a, const T* b, T* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

// Motion transform X = (E, r) applied to m = [w; v]: [E w; E (v - r x w)].
template <class T>
void transform_motion(const T* E, const T* r, const T* m, T* out) {
  T rw[3], t[3];
  cross(r, m, rw);
  for (int k = 0; k < 3; ++k) t[k] = m[3 + k] - rw[k];
  rotate(E, m, out);
  rotate(E, t, out + 3);
}
// Its transpose on a force f = [n; f]: [E^T n + r x (E^T f); E^T f].
template <class T>
void transform_force_back(const T* E, const T* r, const T* f, T* out) {
  T n[3], ff[3], rf[3];
  rotate_back(E, f, n);
  rotate_back(E, f + 3, ff);
  cross(r, ff, rf);
  for (int k = 0; k < 3; ++k) {
    out[k] = n[k] + rf[k];
    out[3 + k] = ff[k];
  }
}

// m x S for S = e_z (revolute: angular z) or e_{z+3} (prismatic: linear z): the sparse columns of
// the motion cross product, written out
template <class T>
void cross_motion_S(const T* m, bool prismatic, T* out) {
  const T zero(0);
  if (!prismatic) {  // [w x z; v x z]
    out[0] = m[1];
    out[1] = -m[0];
    out[2] = zero;
    out[3] = m[4];
    out[4] = -m[3];
    out[5] = zero;
  } else {  // [0; w x z]
    out[0] = zero;
    out[1] = zero;
    out[2] = zero;
    out[3] = m[1];
    out[4] = -m[0];
    out[5] = zero;
  }
}
// S x* f: revolute [z x n + 0; z x f], prismatic [z x f; 0]
template <class T>
void cross_force_S(const T* f, bool prismatic, T* out) {
  const T zero(0);
  if (!prismatic) {
    out[0] = -f[1];
    out[1] = f[0];
    out[2] = zero;
    out[3] = -f[4];
    out[4] = f[3];
    out[5] = zero;
  } else {
    out[0] = -f[4];
    out[1] = f[3];
    out[2] = zero;
    out[3] = zero;
    out[4] = zero;
    out[5] = zero;
  }
}
// m x* f
template <class T>
void cross_force(const T* m, const T* f, T* out) {
  T a[3], b[3], c[3];
  cross(m, f, a);
  cross(m + 3, f + 3, b);
  cross(m, f + 3, c);
  for (int k = 0; k < 3; ++k) {
    out[k] = a[k] + b[k];
    out[3 + k] = c[k];
  }
}
template <class T>
void mul66(const T* I, const T* x, T* out) {
  for (int r = 0; r < 6; ++r) {
    RBDGRAD_HLS_PRAGMA(HLS UNROLL)
    T s = I[6 * r] * x[0];
    for (int c = 1; c < 6; ++c) s += I[6 * r + c] * x[c];
    out[r] = s;
  }
}
// sum over k < n of a[k] b[k * stride] with every product kept whole and one rounding at the end,
// as an HLS multiply-accumulate does (full-width ap_fixed products into a wide accumulator, a
// DSP's 48-bit one). The products with M^-1 need it: its entries reach about 1e3 on iiwa14, and
// a single product with a derivative would leave Q16.16 although the sum fits.
template <class T>
struct WideDot {
  static T dot(const T* a, const T* b, int n, int stride) {
    T acc(0);
    for (int k = 0; k < n; ++k) acc += a[k] * b[k * stride];
    return acc;
  }
};
template <int W, int F>
struct WideDot<Fixed<W, F>> {
  static Fixed<W, F> dot(const Fixed<W, F>* a, const Fixed<W, F>* b, int n, int stride) {
    using ::rbdgrad::detail::int128;
    int128 acc = 0;  // products have 2F fractional bits; 32 of them fit with room for the sum
    for (int k = 0; k < n; ++k) acc += int128{a[k].raw()} * int128{b[k * stride].raw()};
    const int128 raw = ::rbdgrad::detail::round_shift_right(acc, F);
    // out of the format's range: saturate and flag, as every Fixed operation does
    if (raw > int128{Fixed<W, F>::raw_max} || raw < int128{Fixed<W, F>::raw_min}) {
      ::rbdgrad::detail::record_fixed_overflow();
      return Fixed<W, F>::from_raw(raw > 0 ? Fixed<W, F>::raw_max : Fixed<W, F>::raw_min);
    }
    return Fixed<W, F>::from_raw(static_cast<std::int64_t>(raw));
  }
};

// the S component of a 6-vector: S^T x
template <class T>
T along_S(const T* x, bool prismatic) {
  return prismatic ? x[5] : x[2];
}

}  // namespace detail

// The joint transforms of the state from sin and cos of the angles (and the prismatic offsets,
// from q itself): E = (R0 Rz(q))^T, r = p0 (+ q R0 e_z for a prismatic joint).
template <class T, int MaxNv>
void joint_transforms(const RobotConstants<T, MaxNv>& robot, const T* q, const T* sin_q, const T* cos_q,
                      KernelState<T, MaxNv>& s) {
  for (int i = 0; i < robot.nv; ++i) {
    RBDGRAD_HLS_PRAGMA(HLS PIPELINE II = 1)
    const T* R0 = robot.joint_rotation[i];
    T R[9];
    for (int e = 0; e < 9; ++e) R[e] = R0[e];
    for (int k = 0; k < 3; ++k) s.r[i][k] = robot.joint_translation[i][k];
    if (!robot.prismatic[i]) {
      // R0 Rz(q): only the first two columns mix
      for (int row = 0; row < 3; ++row) {
        R[3 * row] = cos_q[i] * R0[3 * row] + sin_q[i] * R0[3 * row + 1];
        R[3 * row + 1] = cos_q[i] * R0[3 * row + 1] - sin_q[i] * R0[3 * row];
      }
    } else {
      for (int k = 0; k < 3; ++k) s.r[i][k] += q[i] * R0[3 * k + 2];
    }
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) s.E[i][3 * row + col] = R[3 * col + row];
  }
}

// RNEA at (q, qd, qdd) with its gradient columns fused into the same forward sweep (Algorithm 5,
// lines 1-4), then the backward sweep of forces and their derivatives (lines 5-7). Leaves tau in
// `tau` and dc/du in s.dc.
// columns: which datapaths run (kColumnsDq: the d/dq columns, kColumnsDqd: the d/dqd columns); the
// others are skipped (ColumnRange) and their s.dc columns left as they were. An unsigned is known at
// run time; FixedColumns<...> fixes them at compile time.
template <class T, int MaxNv, class Columns = unsigned>
void rnea_gradient(const RobotConstants<T, MaxNv>& robot, const T* qd, const T* qdd, KernelState<T, MaxNv>& s,
                   T* tau, Columns columns = kColumnsDq | kColumnsDqd) {
  using namespace detail;
  const int n = robot.nv;
  const T zero(0);
  const T a_gravity[6] = {zero, zero, zero, -robot.gravity[0], -robot.gravity[1], -robot.gravity[2]};
  const T v_world[6] = {zero, zero, zero, zero, zero, zero};
  const ColumnRange cols(columns, n);

  // forward sweep
  for (int i = 0; i < n; ++i) {
    const int par = robot.parent[i];
    const bool pr = robot.prismatic[i];
    const T* vp = par < 0 ? v_world : s.v[par];
    const T* ap = par < 0 ? a_gravity : s.a[par];
    transform_motion(s.E[i], s.r[i], vp, s.Xv[i]);
    transform_motion(s.E[i], s.r[i], ap, s.Xa[i]);
    // v = X vp + S qd; a = X ap + S qdd + v x S qd
    for (int k = 0; k < 6; ++k) s.v[i][k] = s.Xv[i][k];
    s.v[i][pr ? 5 : 2] += qd[i];
    T vxS[6];
    cross_motion_S(s.v[i], pr, vxS);
    for (int k = 0; k < 6; ++k) s.a[i][k] = s.Xa[i][k] + vxS[k] * qd[i];
    s.a[i][pr ? 5 : 2] += qdd[i];
    // f = I a + v x* I v
    T Ia[6], vxh[6];
    mul66(robot.inertia[i], s.v[i], s.h[i]);
    mul66(robot.inertia[i], s.a[i], Ia);
    cross_force(s.v[i], s.h[i], vxh);
    for (int k = 0; k < 6; ++k) s.f[i][k] = Ia[k] + vxh[k];

    // the columns of the derivatives: one datapath each, those `columns` selects
    for (int j = cols.begin; j < cols.end; ++j) {
      RBDGRAD_HLS_PRAGMA(HLS UNROLL factor = 2)
      const bool wrt_q = is_q_column(columns, j, n);
      const int joint = wrt_q ? j : j - n;
      T* dv = s.dv[i][j];
      T* da = s.da[i][j];
      if (par < 0) {
        for (int k = 0; k < 6; ++k) dv[k] = da[k] = zero;
      } else {
        transform_motion(s.E[i], s.r[i], s.dv[par][j], dv);
        transform_motion(s.E[i], s.r[i], s.da[par][j], da);
      }
      // d(X m)/dq_i = (X m) x S; d(S qd)/dqd_i = S
      if (joint == i) {
        if (wrt_q) {
          T t[6];
          cross_motion_S(s.Xv[i], pr, t);
          for (int k = 0; k < 6; ++k) dv[k] += t[k];
        } else {
          dv[pr ? 5 : 2] += T(1);
        }
      }
      // da = X da_par + dv x S qd (+ X a_par x S for q_i, + v x S for qd_i)
      T t[6];
      cross_motion_S(dv, pr, t);
      for (int k = 0; k < 6; ++k) da[k] += t[k] * qd[i];
      if (joint == i) {
        cross_motion_S(wrt_q ? s.Xa[i] : s.v[i], pr, t);
        for (int k = 0; k < 6; ++k) da[k] += t[k];
      }
      // df = I da + dv x* h + v x* (I dv)
      T Ida[6], Idv[6], c1[6], c2[6];
      mul66(robot.inertia[i], da, Ida);
      mul66(robot.inertia[i], dv, Idv);
      cross_force(dv, s.h[i], c1);
      cross_force(s.v[i], Idv, c2);
      for (int k = 0; k < 6; ++k) s.df[i][j][k] = Ida[k] + c1[k] + c2[k];
    }
  }

  // backward sweep
  for (int i = n - 1; i >= 0; --i) {
    const int par = robot.parent[i];
    const bool pr = robot.prismatic[i];
    tau[i] = along_S(s.f[i], pr);
    for (int j = cols.begin; j < cols.end; ++j) {
      RBDGRAD_HLS_PRAGMA(HLS UNROLL factor = 2)
      s.dc[i][j] = along_S(s.df[i][j], pr);
      if (par < 0) continue;
      // df_par += X^T df (+ X^T (S x* f) for q_i)
      T t[6];
      transform_force_back(s.E[i], s.r[i], s.df[i][j], t);
      for (int k = 0; k < 6; ++k) s.df[par][j][k] += t[k];
      if (is_own_q_column(columns, j, i)) {
        T Sf[6], u[6];
        cross_force_S(s.f[i], pr, Sf);
        transform_force_back(s.E[i], s.r[i], Sf, u);
        for (int k = 0; k < 6; ++k) s.df[par][j][k] += u[k];
      }
    }
    if (par >= 0) {
      T t[6];
      transform_force_back(s.E[i], s.r[i], s.f[i], t);
      for (int k = 0; k < 6; ++k) s.f[par][k] += t[k];
    }
  }
}

// The whole gradient of one state: qdd (from tau through M^-1, or given), then dc/du at it, then
// dqdd/du = -M^-1 dc/du. Outputs row-major nv x nv; qdd_out receives the qdd used. `columns` says
// which of dqdd_dq and dqdd_dqd are computed (a scene's skips: the other datapaths are bypassed and
// their output left as it was; an unsigned at run time, FixedColumns<...> at compile time).
template <class T, int MaxNv, class Columns = unsigned>
void fd_gradient(const RobotConstants<T, MaxNv>& robot, const T* q, const T* sin_q, const T* cos_q, const T* qd,
                 const T* u, bool tau_input, const T* minv, KernelState<T, MaxNv>& s, T* qdd_out, T* dqdd_dq,
                 T* dqdd_dqd, Columns columns = kColumnsDq | kColumnsDqd) {
  const int n = robot.nv;
  joint_transforms(robot, q, sin_q, cos_q, s);
  T tau[MaxNv];
  if (tau_input) {
    // c = RNEA(q, qd, 0), qdd = M^-1 (tau - c)
    T zeros[MaxNv];
    for (int i = 0; i < n; ++i) zeros[i] = T(0);
    // the bias c alone: its derivative columns would be overwritten below
    rnea_gradient(robot, qd, zeros, s, tau, 0u);
    T bias[MaxNv];
    for (int k = 0; k < n; ++k) bias[k] = u[k] - tau[k];
    for (int i = 0; i < n; ++i) qdd_out[i] = detail::WideDot<T>::dot(minv + i * n, bias, n, 1);
  } else {
    for (int i = 0; i < n; ++i) qdd_out[i] = u[i];
  }
  rnea_gradient(robot, qd, qdd_out, s, tau, columns);
  // -M^-1 dc/du, one column per datapath
  const ColumnRange cols(columns, n);
  for (int j = cols.begin; j < cols.end; ++j) {
    RBDGRAD_HLS_PRAGMA(HLS UNROLL factor = 2)
    const bool wrt_q = detail::is_q_column(columns, j, n);
    T* out = wrt_q ? dqdd_dq : dqdd_dqd;
    const int col = wrt_q ? j : j - n;
    for (int row = 0; row < n; ++row) out[row * n + col] = -detail::WideDot<T>::dot(minv + row * n, &s.dc[0][j], n, 2 * MaxNv);
  }
}

}  // namespace rbdgrad::fpga
