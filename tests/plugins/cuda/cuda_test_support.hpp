// Shared by the CUDA backend's tests: seeded random states, the output cases, the arrays of one
// batch poisoned with NaN, and the comparison of a batch's outputs with the core library.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "../../support/error_statistics.hpp"
#include "../../support/test_models.hpp"
#include "../support/core_reference.hpp"
#include "../support/output_cases.hpp"
#include "device/fused_state.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/plugin_api.h"

namespace rbdgrad::testing {

inline Model robot_model(const std::string& name) {
  if (name == "random_tree") return random_model(21, 12, TreeShape::kBranching);
  if (name == "wide_tree") return random_model(5, 21, TreeShape::kWide);
  return load_embedded(name);
}

// The gradient requests the block kernel takes (device/block_fused_state.hpp); the others go to
// the one-thread kernel.
inline constexpr std::uint32_t kOutputDqdd = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
inline constexpr OutputCase kBlockCases[] = {
    {"d qdd", kOutputDqdd, false, false},
    {"qdd, M^-1 and d qdd, external forces", kOutputDqdd | RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV, true, false},
    {"d qdd/d q alone, external forces", RBDGRAD_OUTPUT_DQDD_DQ, true, false},
    {"d qdd/d qd and qdd", RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD, false, false},
    {"qdd and M^-1", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV, false, false},
    {"d qdd with supplied M^-1", kOutputDqdd, false, true},
    {"qdd and d qdd/d qd with supplied M^-1, external forces", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQD, true, true},
};

// One state's inputs in double.
struct StateInputs {
  Eigen::VectorXd q, qd, tau, qdd, fext;  // (nv), fext (6 nv)
  Eigen::MatrixXd minv;                   // (nv x nv) a "cached" M^-1: taken at a nearby q, slightly unsymmetric
};

inline std::vector<StateInputs> random_inputs(const Model& m, std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  Workspace ws(m);
  std::vector<StateInputs> out(n);
  for (StateInputs& s : out) {
    s.q = random_vector(rng, m.nv, 2.0);
    s.qd = random_vector(rng, m.nv, 1.5);
    s.tau = random_vector(rng, m.nv, 8.0);
    s.qdd = random_vector(rng, m.nv, 3.0);
    s.fext = random_vector(rng, 6 * m.nv, 2.0);
    if (!minverse(m, ws, Eigen::VectorXd(s.q + random_vector(rng, m.nv, 0.05))))
      throw std::runtime_error("minverse failed");
    const Eigen::MatrixXd noise = random_vector(rng, m.nv * m.nv, 1e-3).reshaped(m.nv, m.nv);
    s.minv = ws.Minv + noise.cwiseProduct(ws.Minv);
  }
  return out;
}

template <class S>
S poison() {
  return std::numeric_limits<S>::quiet_NaN();
}

// The arrays of one batch in S: inputs from `states`, outputs and status poisoned.
template <class S>
struct CudaBatch {
  CudaBatch(const std::vector<StateInputs>& states, int joints, bool tau_input)
      : n(states.size()), nv(static_cast<std::size_t>(joints)) {
    for (const StateInputs& s : states) {
      append(q, s.q);
      append(qd, s.qd);
      append(u, tau_input ? s.tau : s.qdd);
      append(fext, s.fext);
      for (std::size_t i = 0; i < nv; ++i)
        for (std::size_t j = 0; j < nv; ++j)
          minv.push_back(static_cast<S>(s.minv(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j))));
    }
    for (int f = 0; f < 8; ++f) out[f].resize(is_matrix(1u << f) ? n * nv * nv : n * nv);
    status.resize(n);
  }

  static bool is_matrix(std::uint32_t flag) { return flag != RBDGRAD_OUTPUT_QDD && flag != RBDGRAD_OUTPUT_TAU; }

  void poison() {
    for (std::vector<S>& o : out) std::fill(o.begin(), o.end(), testing::poison<S>());
    std::fill(status.begin(), status.end(), std::int32_t{-1});
  }

  // for the host run of the device code
  cuda::BatchPointers<S> pointers(const OutputCase& c, bool tau_input) {
    cuda::BatchPointers<S> b;
    b.n = n;
    b.outputs = c.outputs;
    b.tau_input = tau_input;
    b.q = q.data();
    b.qd = qd.data();
    b.u = u.data();
    b.fext = c.fext ? fext.data() : nullptr;
    b.minv = c.minv ? minv.data() : nullptr;
    for (int f = 0; f < 8; ++f) b.out[f] = (c.outputs & (1u << f)) ? out[f].data() : nullptr;
    return b;
  }

  // for the plugin: every output pointer set, as the daemon does (the plugin writes only what is asked)
  rbdgrad_batch batch(std::uint32_t precision, const OutputCase& c, bool tau_input) {
    rbdgrad_batch b{};
    b.struct_size = sizeof(b);
    b.n = n;
    b.precision = precision;
    b.input_kind = tau_input ? RBDGRAD_INPUT_TAU : RBDGRAD_INPUT_QDD;
    b.outputs = c.outputs;
    b.q = q.data();
    b.qd = qd.data();
    b.u = u.data();
    b.minv = c.minv ? minv.data() : nullptr;
    b.fext = c.fext ? fext.data() : nullptr;
    void** fields[8] = {&b.qdd, &b.minv_out, &b.dqdd_dq, &b.dqdd_dqd, &b.tau, &b.dtau_dq, &b.dtau_dqd, &b.m};
    for (int f = 0; f < 8; ++f) *fields[f] = out[f].data();
    b.state_status = status.data();
    return b;
  }

  std::size_t n, nv;
  std::vector<S> q, qd, u, fext, minv;
  std::vector<S> out[8];  // per output flag, log2 order
  std::vector<std::int32_t> status;

 private:
  void append(std::vector<S>& to, const Eigen::VectorXd& x) {
    for (Eigen::Index i = 0; i < x.size(); ++i) to.push_back(static_cast<S>(x(i)));
  }
};

// The relative Frobenius error of every requested output of every state against the core.
struct Comparison {
  std::string message;  // the first unwritten, overwritten or refused element; empty when none
  // per output flag index: errors against the core in the batch's scalar (for f32 also against
  // the core in f64 on the same inputs, next to the core f32's own error there)
  std::vector<double> error[8], error_vs_f64[8], core_f32_error[8];

  // f64: within 1e-10 of the core everywhere. f32: as accurate as the core's f32 against f64 on
  // the same inputs, with the core's f32 bounds (median 1e-4, worst 1e-3) as the floor, since the
  // two f32 computations round differently (the GPU contracts multiply-adds into FMAs).
  template <class S>
  bool within_bounds() const {
    for (int f = 0; f < 8; ++f) {
      if constexpr (std::is_same_v<S, double>) {
        if (worst_of(error[f]) > 1e-10) return false;
      } else {
        if (median_of(error_vs_f64[f]) > std::max(1e-4, 4 * median_of(core_f32_error[f]))) return false;
        for (std::size_t k = 0; k < error_vs_f64[f].size(); ++k)
          if (error_vs_f64[f][k] > std::max(1e-3, 4 * core_f32_error[f][k])) return false;
      }
    }
    return true;
  }

  std::string summary() const {
    std::ostringstream s;
    s.precision(2);
    for (int f = 0; f < 8; ++f) {
      if (error[f].empty()) continue;
      s << " " << plugin_output_name(f) << " " << std::scientific << median_of(error[f]) << "/" << worst_of(error[f]);
      if (!error_vs_f64[f].empty())
        s << " (vs f64 " << median_of(error_vs_f64[f]) << "/" << worst_of(error_vs_f64[f]) << ", core f32 "
          << median_of(core_f32_error[f]) << "/" << worst_of(core_f32_error[f]) << ")";
    }
    return s.str();
  }

  static const char* plugin_output_name(int f) {
    constexpr const char* kNames[8] = {"qdd", "minv", "dqdd_dq", "dqdd_dqd", "tau", "dtau_dq", "dtau_dqd", "m"};
    return kNames[f];
  }
};

template <class S>
ReferenceInputs<S> reference_inputs(const CudaBatch<S>& a, std::size_t k, const OutputCase& c) {
  const auto nv = static_cast<Eigen::Index>(a.nv);
  ReferenceInputs<S> in;
  auto vec = [&](const std::vector<S>& src, Eigen::Index len) {
    return Eigen::Map<const VectorX<S>>(src.data() + k * static_cast<std::size_t>(len), len).eval();
  };
  in.q = vec(a.q, nv);
  in.qd = vec(a.qd, nv);
  in.u = vec(a.u, nv);
  in.fext = vec(a.fext, 6 * nv);
  in.minv = Eigen::Map<const Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      a.minv.data() + k * a.nv * a.nv, nv, nv);
  in.with_fext = c.fext;
  in.with_minv = c.minv;
  return in;
}

template <class T>
ReferenceInputs<double> to_double(const ReferenceInputs<T>& in) {
  ReferenceInputs<double> out;
  out.q = in.q.template cast<double>();
  out.qd = in.qd.template cast<double>();
  out.u = in.u.template cast<double>();
  out.fext = in.fext.template cast<double>();
  out.minv = in.minv.template cast<double>();
  out.with_fext = in.with_fext;
  out.with_minv = in.with_minv;
  return out;
}

// Compares every state of a computed batch with the core, states [0, count) (all by default).
template <class S>
Comparison compare_with_core(const Model& model, const CudaBatch<S>& a, const OutputCase& c, bool tau_input,
                             std::size_t count = std::numeric_limits<std::size_t>::max()) {
  Comparison cmp;
  const ModelTpl<S> ms = model.cast<S>();
  WorkspaceTpl<S> ws(ms);
  Workspace ws64(model);
  const std::size_t nv = a.nv;
  for (std::size_t k = 0; k < std::min(count, a.n); ++k) {
    std::map<std::uint32_t, MatrixX<S>> ref;
    const ReferenceInputs<S> in = reference_inputs(a, k, c);
    if (Status s = reference_state(ms, ws, in, tau_input, c.outputs, ref); !s) {
      cmp.message = "state " + std::to_string(k) + ": the core refused it: " + s.message();
      return cmp;
    }
    std::map<std::uint32_t, Eigen::MatrixXd> ref64;
    if constexpr (!std::is_same_v<S, double>) {
      if (Status s = reference_state(model, ws64, to_double(in), tau_input, c.outputs, ref64); !s) {
        cmp.message = "state " + std::to_string(k) + ": the core refused it in f64: " + s.message();
        return cmp;
      }
    }
    for (int f = 0; f < 8; ++f) {
      const std::uint32_t flag = 1u << f;
      const bool matrix = CudaBatch<S>::is_matrix(flag);
      const std::size_t per = matrix ? nv * nv : nv;
      const S* got = a.out[f].data() + k * per;
      if (!(c.outputs & flag)) {
        // outputs that were not asked for keep their poison, bit for bit
        const S p = poison<S>();
        for (std::size_t i = 0; i < per; ++i)
          if (std::memcmp(&got[i], &p, sizeof(S)) != 0) {
            cmp.message = "state " + std::to_string(k) + ": " + Comparison::plugin_output_name(f) + " element " +
                          std::to_string(i) + " was written but not requested";
            return cmp;
          }
        continue;
      }
      Eigen::MatrixXd g(matrix ? nv : nv, matrix ? nv : 1);
      for (std::size_t i = 0; i < per; ++i) {
        if (!std::isfinite(static_cast<double>(got[i]))) {
          cmp.message = "state " + std::to_string(k) + ": " + Comparison::plugin_output_name(f) + " element " +
                        std::to_string(i) + " is " + std::to_string(static_cast<double>(got[i])) +
                        " (unwritten or not finite)";
          return cmp;
        }
        if (matrix) g(static_cast<Eigen::Index>(i / nv), static_cast<Eigen::Index>(i % nv)) = got[i];
        else g(static_cast<Eigen::Index>(i), 0) = got[i];
      }
      const Eigen::MatrixXd r = ref.at(flag).template cast<double>();
      cmp.error[f].push_back(relative_error(g, r));
      if constexpr (!std::is_same_v<S, double>) {
        cmp.error_vs_f64[f].push_back(relative_error(g, ref64.at(flag)));
        cmp.core_f32_error[f].push_back(relative_error(r, ref64.at(flag)));
      }
    }
  }
  return cmp;
}

}  // namespace rbdgrad::testing
