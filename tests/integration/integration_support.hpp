// What the integration tests share: the daemon's configuration, seeded random batches, and the
// expected results of a batch computed in this process by the core library (the computation the
// CPU plugin documents it follows, see tests/plugins/support/core_reference.hpp).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "../plugins/support/core_reference.hpp"
#include "../support/test_models.hpp"
#include "daemon_process.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::testing {

inline constexpr const char* kRobots[] = {"iiwa14", "panda", "talos_reduced", "hyq"};

// every embedded robot under its own name; `extra` is appended verbatim (plugins, limits)
inline std::string daemon_config(const std::string& extra = "") {
  std::string yaml = "models:\n";
  for (const char* r : kRobots) yaml += std::string("  - name: ") + r + "\n    embedded: " + r + "\n";
  return yaml + "log_level: warn\n" + extra;
}

// A batch of N states: q within +-1.5 rad, qd within +-2 rad/s, u (tau or qdd) within +-5.
struct Batch {
  std::string model;
  int nv = 0;
  std::uint32_t n = 0;
  std::vector<double> q, qd, u;

  ComputeRequest request(std::uint32_t outputs, ComputeInput input = ComputeInput::kTau,
                         Precision precision = Precision::kF64) const {
    ComputeRequest r;
    r.model = model;
    r.num_states = n;
    r.precision = precision;
    r.input = input;
    r.outputs = outputs;
    r.q = q;
    r.qd = qd;
    r.u = u;
    return r;
  }
};

inline Batch random_batch(const std::string& model, int nv, std::uint32_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-1.5, 1.5), vel(-2, 2), acc(-5, 5);
  Batch b{model, nv, n, {}, {}, {}};
  const size_t count = static_cast<size_t>(n) * static_cast<size_t>(nv);
  for (size_t i = 0; i < count; ++i) {
    b.q.push_back(pos(rng));
    b.qd.push_back(vel(rng));
    b.u.push_back(acc(rng));
  }
  return b;
}

// Expected outputs of every state of `b`, flattened state-major and row-major like the wire
// format: expected[output flag] has N x nv or N x nv x nv values.
inline std::map<std::uint32_t, std::vector<double>> expected_outputs(const Model& model, const Batch& b,
                                                                     std::uint32_t outputs, bool tau_input) {
  WorkspaceTpl<double> ws(model);
  std::map<std::uint32_t, std::vector<double>> expected;
  const int nv = model.nv;
  for (std::uint32_t k = 0; k < b.n; ++k) {
    ReferenceInputs<double> in;
    const auto seg = [&](const std::vector<double>& v) {
      return Eigen::Map<const Eigen::VectorXd>(v.data() + static_cast<size_t>(k) * nv, nv).eval();
    };
    in.q = seg(b.q);
    in.qd = seg(b.qd);
    in.u = seg(b.u);
    std::map<std::uint32_t, MatrixX<double>> out;
    const Status s = reference_state(model, ws, in, tau_input, outputs, out);
    if (!s) throw std::runtime_error("state " + std::to_string(k) + ": " + s.to_string());
    for (auto& [flag, m] : out) {
      // row-major, as on the wire
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rm = m;
      std::vector<double>& dst = expected[flag];
      dst.insert(dst.end(), rm.data(), rm.data() + rm.size());
    }
  }
  return expected;
}

// Whether every requested output of `r` equals `expected` bit for bit; the first mismatch otherwise.
inline ::testing::AssertionResult bitwise_equal(const ComputeResult& r,
                                               const std::map<std::uint32_t, std::vector<double>>& expected) {
  for (const auto& [flag, values] : expected) {
    const auto o = static_cast<Output>(flag);
    const std::span<const double> got = r.block(o);
    if (got.size() != values.size())
      return ::testing::AssertionFailure() << output_name(o) << ": " << got.size() << " values, expected "
                                           << values.size();
    if (std::memcmp(got.data(), values.data(), values.size() * sizeof(double)) != 0) {
      for (size_t i = 0; i < values.size(); ++i)
        if (std::memcmp(&got[i], &values[i], sizeof(double)) != 0)
          return ::testing::AssertionFailure() << output_name(o) << " element " << i << ": got " << got[i]
                                               << ", expected " << values[i];
    }
  }
  return ::testing::AssertionSuccess();
}

}  // namespace rbdgrad::testing
