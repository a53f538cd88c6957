// One state of a batch, every requested output, in one thread: the completely fused partitioning
// of paper 000 (section IV-B): RNEA (v', a', f'), its gradient, M^-1 and -M^-1 dc'/du all on the
// device. The choice of algorithms follows core/src/algorithm/evaluate.cpp, and each step checks
// its outputs as the core's NumericGuard does, so that a state fails for the same reason and with
// the same message on the CPU and the GPU.
#pragma once

#include "articulated_body_pass.hpp"
#include "mass_inverse.hpp"
#include "output_flags.hpp"
#include "state_status.hpp"

namespace rbdgrad::cuda {

// One batch in device memory (state-major, matrices row-major, as plugin_api.h lays them out).
template <class S>
struct BatchPointers {
  std::uint64_t n = 0;
  std::uint32_t outputs = 0;       // rbdgrad_output flags
  bool tau_input = true;           // u holds tau (else qdd)
  const S* q = nullptr;            // (n x nv)
  const S* qd = nullptr;           // (n x nv), null when only M is requested
  const S* u = nullptr;            // (n x nv), null when only M is requested
  const S* fext = nullptr;         // (n x 6 nv) or null
  const S* minv = nullptr;         // (n x nv x nv) caller's M^-1 or null
  S* out[kOutputCount] = {};       // per output_index: (n x nv) or (n x nv x nv), null when not requested
  std::uint32_t* status = nullptr; // (n) state_status encoding, 0 = computed
};

template <class S, class Vector>
RBDGRAD_HD bool all_finite(const Vector& x, int count) {
  for (int k = 0; k < count; ++k)
    if (!is_finite(S(x[k]))) return false;
  return true;
}

// M and the inverse-dynamics derivatives hold values only where related(i, j): the other entries
// are zero by structure and never written in the workspace
template <class S>
RBDGRAD_HD bool all_finite(const ModelView<S>& m, const StridedMatrix<S>& x, bool tree_sparse) {
  for (int i = 0; i < m.nv; ++i)
    for (int j = 0; j < m.nv; ++j)
      if ((!tree_sparse || m.related(i, j)) && !is_finite(x(i, j))) return false;
  return true;
}

template <class S>
RBDGRAD_HD std::uint32_t not_finite(Algorithm algorithm) {
  return state_status(Reason::kNotFinite, algorithm, 0);
}

// M(q): forward pass of placements and inertias, backward pass of composite inertias.
template <class S>
RBDGRAD_HD std::uint32_t crba(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q) {
  forward_pass<S, Level::kInertia>(m, ws, q, nullptr, NoQdd{}, nullptr);
  backward_pass<S, Level::kInertia>(m, ws, /*with_mass=*/true, /*with_dq=*/false);
  return all_finite(m, ws.M, true) ? 0 : not_finite<S>(Algorithm::kCrba);
}

// M^-1(q) into ws.Minv (and M into ws.M).
template <class S>
RBDGRAD_HD std::uint32_t minverse(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q) {
  if (std::uint32_t s = crba(m, ws, q)) return s;
  if (std::uint32_t s = factorize_mass_matrix(m, ws)) return s;
  inverse_from_factors(m, ws);
  return all_finite(m, ws.Minv, false) ? 0 : not_finite<S>(Algorithm::kMinverse);
}

// qdd = FD(q, qd, tau) into ws.qdd by the articulated-body pass.
template <class S>
RBDGRAD_HD std::uint32_t forward_dynamics(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q, const S* qd,
                                          const S* tau, const S* fext) {
  forward_pass<S, Level::kDynamics>(m, ws, q, qd, NoQdd{}, fext, /*for_aba=*/true);
  articulated_body_pass(m, ws, qd, tau, fext, ws.qdd);
  return all_finite<S>(ws.qdd, m.nv) ? 0 : not_finite<S>(Algorithm::kForwardDynamics);
}

// d qdd / d(q, qd) = -M^-1 dc'/du (paper 000, Algorithm 3), with qdd, M, tau = c' and the
// derivatives of c' on the way; M^-1 from the factors of M unless the caller supplied it.
template <class S>
RBDGRAD_HD std::uint32_t fd_derivatives(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q, const S* qd,
                                        const S* input, bool tau_input, const S* fext, const S* supplied_minv) {
  const int n = m.nv;
  bool factored = false;
  auto inverse = [&]() -> std::uint32_t {
    if (supplied_minv) return 0;
    if (std::uint32_t s = factorize_mass_matrix(m, ws)) return s;
    inverse_from_factors(m, ws);
    factored = true;
    return 0;
  };
  const DenseMatrix<S> caller_minv{supplied_minv, n};
  // step 1 (Algorithm 1): RNEA quantities v', a', f'; step 2 (Algorithm 2): the derivatives of c'
  if (!tau_input) {
    forward_pass<S, Level::kDerivatives>(m, ws, q, qd, input, fext);
    backward_pass<S, Level::kDerivatives>(m, ws, /*with_mass=*/true, /*with_dq=*/true);
    if (std::uint32_t s = inverse()) return s;
    for (int i = 0; i < n; ++i) ws.qdd[i] = input[i];
  } else if constexpr (std::is_same_v<S, double>) {
    // f64: c, M and d tau/d qd at qdd = 0; qdd = M^-1 (tau - c); then the qdd part and d tau/d q
    forward_pass<S, Level::kDerivatives>(m, ws, q, qd, NoQdd{}, fext);
    backward_pass<S, Level::kDerivatives>(m, ws, /*with_mass=*/true, /*with_dq=*/false);
    if (std::uint32_t s = inverse()) return s;
    if (factored) {
      for (int i = 0; i < n; ++i) ws.qdd[i] = input[i] - ws.tau[i];
      solve_with_factors(m, ws, ws.qdd);
    } else {
      for (int i = 0; i < n; ++i) {
        S s = S(0);
        for (int j = 0; j < n; ++j) s += caller_minv(i, j) * (input[j] - ws.tau[j]);
        ws.qdd[i] = s;
      }
    }
    add_acceleration_pass(m, ws, ws.qdd, /*into_body_force=*/false);
    derivative_dq_pass(m, ws);
    for (int i = 0; i < n; ++i) ws.tau[i] = input[i];
  } else {
    // f32: qdd by the articulated-body pass about the joint points, on the same velocities
    forward_pass<S, Level::kDerivatives>(m, ws, q, qd, NoQdd{}, fext, /*for_aba=*/true);
    articulated_body_pass(m, ws, qd, input, fext, ws.qdd);
    add_acceleration_pass(m, ws, ws.qdd, /*into_body_force=*/true);
    backward_pass<S, Level::kDerivatives>(m, ws, /*with_mass=*/true, /*with_dq=*/true);
    if (std::uint32_t s = inverse()) return s;
  }
  // step 3: dqdd/du = -M^-1 dc'/du
  if (supplied_minv) {
    multiply_by_minus_minv(m, caller_minv, ws.dtau_dq, ws.dqdd_dq);
    multiply_by_minus_minv(m, caller_minv, ws.dtau_dqd, ws.dqdd_dqd);
  } else {
    multiply_by_minus_minv(m, ws.Minv, ws.dtau_dq, ws.dqdd_dq);
    multiply_by_minus_minv(m, ws.Minv, ws.dtau_dqd, ws.dqdd_dqd);
  }
  const bool finite = all_finite<S>(ws.qdd, n) && (!factored || all_finite(m, ws.Minv, false)) &&
                      all_finite(m, ws.dqdd_dq, false) && all_finite(m, ws.dqdd_dqd, false);
  return finite ? 0 : not_finite<S>(Algorithm::kFdDerivatives);
}

// tau = RNEA(q, qd, qdd) and, with derivatives, d tau / d(q, qd) and M.
template <class S>
RBDGRAD_HD std::uint32_t rnea(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q, const S* qd,
                              const S* fext, bool derivatives) {
  if (derivatives) {
    forward_pass<S, Level::kDerivatives>(m, ws, q, qd, ws.qdd, fext);
    backward_pass<S, Level::kDerivatives>(m, ws, /*with_mass=*/true, /*with_dq=*/true);
    const bool finite = all_finite<S>(ws.tau, m.nv) && all_finite(m, ws.dtau_dq, true) && all_finite(m, ws.dtau_dqd, true);
    return finite ? 0 : not_finite<S>(Algorithm::kRneaDerivatives);
  }
  forward_pass<S, Level::kDynamics>(m, ws, q, qd, ws.qdd, fext);
  backward_pass<S, Level::kDynamics>(m, ws, /*with_mass=*/false, /*with_dq=*/false);
  return all_finite<S>(ws.tau, m.nv) ? 0 : not_finite<S>(Algorithm::kRnea);
}

// Writes one field of state k into its output array (row-major); tree_sparse matrices get their
// structural zeros written explicitly.
template <class S>
RBDGRAD_HD void write_vector(const Strided<S>& x, int nv, S* out) {
  for (int i = 0; i < nv; ++i) out[i] = x[i];
}
template <class S>
RBDGRAD_HD void write_matrix(const ModelView<S>& m, const StridedMatrix<S>& x, bool tree_sparse, S* out) {
  for (int i = 0; i < m.nv; ++i)
    for (int j = 0; j < m.nv; ++j) out[i * m.nv + j] = !tree_sparse || m.related(i, j) ? x(i, j) : S(0);
}

// Computes the requested outputs of state k and writes them; returns its status (0 = computed).
// Runs only the algorithms the outputs need, as evaluate_outputs does.
template <class S>
RBDGRAD_HD std::uint32_t evaluate_state(const ModelView<S>& m, const WorkspaceView<S>& ws, const BatchPointers<S>& b,
                                        std::uint64_t k) {
  const int n = m.nv;
  const std::uint64_t vec = static_cast<std::uint64_t>(n), mat = vec * vec;
  const S* q = b.q + k * vec;
  const S* qd = b.qd ? b.qd + k * vec : nullptr;
  const S* u = b.u ? b.u + k * vec : nullptr;
  const S* fext = b.fext ? b.fext + k * 6 * vec : nullptr;
  const S* minv = b.minv ? b.minv + k * mat : nullptr;
  auto want = [&](std::uint32_t flags) { return (b.outputs & flags) != 0; };
  const bool want_fd = want(kOutputMinv | kOutputDqddDq | kOutputDqddDqd);
  const bool want_id_derivatives = want(kOutputDtauDq | kOutputDtauDqd);
  const bool want_id = want(kOutputTau) || want_id_derivatives;
  bool have_M = false;  // fd_derivatives and the rnea derivatives leave M(q) in ws.M

  // forward dynamics: the derivatives when asked for, else only the qdd that is needed
  if (want_fd) {
    if (std::uint32_t s = fd_derivatives(m, ws, q, qd, u, b.tau_input, fext, minv)) return s;
    have_M = true;
    if (want(kOutputMinv) && minv) {
      if (std::uint32_t s = minverse(m, ws, q)) return s;
    }
  } else if (b.tau_input && (want(kOutputQdd) || want_id)) {
    if (std::uint32_t s = forward_dynamics(m, ws, q, qd, u, fext)) return s;
  } else if (!b.tau_input && u) {
    for (int i = 0; i < n; ++i) ws.qdd[i] = u[i];
  }
  // inverse dynamics at that qdd
  if (want_id) {
    if (std::uint32_t s = rnea(m, ws, q, qd, fext, want_id_derivatives)) return s;
    have_M = have_M || want_id_derivatives;
  }
  if (want(kOutputM) && !have_M) {
    if (std::uint32_t s = crba(m, ws, q)) return s;
  }

  if (S* o = b.out[output_index(kOutputQdd)]) write_vector(ws.qdd, n, o + k * vec);
  if (S* o = b.out[output_index(kOutputMinv)]) write_matrix(m, ws.Minv, false, o + k * mat);
  if (S* o = b.out[output_index(kOutputDqddDq)]) write_matrix(m, ws.dqdd_dq, false, o + k * mat);
  if (S* o = b.out[output_index(kOutputDqddDqd)]) write_matrix(m, ws.dqdd_dqd, false, o + k * mat);
  if (S* o = b.out[output_index(kOutputTau)]) write_vector(ws.tau, n, o + k * vec);
  if (S* o = b.out[output_index(kOutputDtauDq)]) write_matrix(m, ws.dtau_dq, true, o + k * mat);
  if (S* o = b.out[output_index(kOutputDtauDqd)]) write_matrix(m, ws.dtau_dqd, true, o + k * mat);
  if (S* o = b.out[output_index(kOutputM)]) write_matrix(m, ws.M, true, o + k * mat);
  return 0;
}

}  // namespace rbdgrad::cuda
