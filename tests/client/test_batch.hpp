// Inputs for the client tests: a batch of N states with distinct values per state, field and
// element, and the values the fake service answers for it.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::testing {

struct TestBatch {
  std::uint32_t n = 0;
  int nv = 0;
  std::vector<double> q, qd, u;  // n x nv each

  TestBatch(std::uint32_t n_states, int joints, double offset = 0) : n(n_states), nv(joints) {
    for (std::uint32_t k = 0; k < n; ++k) {
      for (int i = 0; i < nv; ++i) {
        q.push_back(offset + 0.5 * k + 0.01 * i);
        qd.push_back(offset - 0.25 * k + 0.1 * i);
        u.push_back(offset + 3.0 * k - 0.7 * i);
      }
    }
  }

  // A request for these inputs; the caller sets outputs and the rest.
  ComputeRequest request(std::string model = "iiwa14") const {
    ComputeRequest r;
    r.model = std::move(model);
    r.num_states = n;
    r.q = q;
    r.qd = qd;
    r.u = u;
    return r;
  }

  // What the fake puts at (i, j) of output o for state k.
  double expected(Output o, std::uint32_t k, int i, int j = 0) const {
    const std::size_t s = static_cast<std::size_t>(k) * static_cast<std::size_t>(nv);
    return fake_output_value(to_proto(o), &q[s], &qd[s], &u[s], i, j);
  }

  static rbdgrad::v1::Output to_proto(Output o) {
    switch (o) {
      case Output::kQdd: return rbdgrad::v1::OUTPUT_QDD;
      case Output::kMinv: return rbdgrad::v1::OUTPUT_MINV;
      case Output::kDqddDq: return rbdgrad::v1::OUTPUT_DQDD_DQ;
      case Output::kDqddDqd: return rbdgrad::v1::OUTPUT_DQDD_DQD;
      case Output::kTau: return rbdgrad::v1::OUTPUT_TAU;
      case Output::kDtauDq: return rbdgrad::v1::OUTPUT_DTAU_DQ;
      case Output::kDtauDqd: return rbdgrad::v1::OUTPUT_DTAU_DQD;
      case Output::kM: return rbdgrad::v1::OUTPUT_M;
    }
    return rbdgrad::v1::OUTPUT_UNSPECIFIED;
  }
};

// Checks every value of every output of `r` against the fake's rule for `batch`; returns "" or
// the first mismatch.
inline std::string check_result_values(const ComputeResult& r, const TestBatch& batch) {
  for (Output o : kEveryOutput) {
    if (!r.has(o)) continue;
    for (std::uint32_t k = 0; k < batch.n; ++k) {
      for (int i = 0; i < batch.nv; ++i) {
        const int cols = is_vector_output(o) ? 1 : batch.nv;
        for (int j = 0; j < cols; ++j) {
          const double want = batch.expected(o, k, i, j);
          double got = 0;
          if (r.output_type() == ScalarType::kF32)
            got = is_vector_output(o) ? r.vector_f32(o, k)(i) : r.matrix_f32(o, k)(i, j);
          else
            got = is_vector_output(o) ? r.vector(o, k)(i) : r.matrix(o, k)(i, j);
          const double tol = r.output_type() == ScalarType::kF32 ? 1e-6 * (1 + std::abs(want)) : 0.0;
          if (std::abs(got - want) > tol)
            return std::string(output_name(o)) + " state " + std::to_string(k) + " (" + std::to_string(i) + "," +
                   std::to_string(j) + "): got " + std::to_string(got) + ", want " + std::to_string(want);
        }
      }
    }
  }
  return "";
}

}  // namespace rbdgrad::testing
