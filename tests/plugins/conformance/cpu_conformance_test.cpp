// Conformance of plugins/cpu with the core library: librbdgrad_cpu.so, loaded through the C ABI as
// the daemon loads it, must give the core's results bit for bit, for every embedded robot (and a
// random tree with prismatic joints), every precision, every output, both input kinds, external
// forces and a caller-supplied M^-1, on 1, 2 and 4 threads. States the core refuses (fixed-point
// overflow) must be refused the same way. The CPU plugin runs each batch through the variant its
// execution plan selects (one d qdd column, no forces, ...): the cases below that skip stages must
// still give the full computation's outputs bit for bit.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/core_reference.hpp"
#include "../support/output_cases.hpp"
#include "../support/plugin_harness.hpp"
#include "common/error.hpp"
#include "common/model_desc.hpp"

namespace rbdgrad::testing {
namespace {

using plugin::SlotT;

constexpr std::size_t kStates = 37;

// requests whose plan skips stages the shared cases (output_cases.hpp) keep: one d qdd column, no
// d qdd column with M^-1, one d tau column
constexpr OutputCase kSkippingCases[] = {
    {"d qdd/d q alone", RBDGRAD_OUTPUT_DQDD_DQ, false, false},
    {"d qdd/d q alone, external forces, supplied M^-1", RBDGRAD_OUTPUT_DQDD_DQ, true, true},
    {"d qdd/d qd and qdd, external forces", RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_QDD, true, false},
    {"d qdd/d qd alone, supplied M^-1", RBDGRAD_OUTPUT_DQDD_DQD, false, true},
    {"M^-1 alone, external forces", RBDGRAD_OUTPUT_MINV, true, false},
    {"d tau/d q and M", RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_M, false, false},
    {"d tau/d qd alone, external forces", RBDGRAD_OUTPUT_DTAU_DQD, true, false},
};

std::vector<OutputCase> every_case() {
  std::vector<OutputCase> cases(std::begin(kOutputCases), std::end(kOutputCases));
  cases.insert(cases.end(), std::begin(kSkippingCases), std::end(kSkippingCases));
  return cases;
}
constexpr int kThreadCounts[] = {1, 2, 4};

const rbdgrad_plugin_api* cpu_api() {
  static const rbdgrad_plugin_api* api =
      load_plugin_entry(RBDGRAD_CPU_PLUGIN_PATH)(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  return api;
}


Model robot_model(const std::string& name) {
  if (name == "random_tree") return random_model(21, 12, TreeShape::kBranching);
  return load_embedded(name);
}

// Seeded random inputs in double, the same for every precision.
struct States {
  std::vector<double> q, qd, tau, qdd, fext, minv;
};

States random_states(const Model& m, unsigned seed) {
  std::mt19937 rng(seed);
  const int nv = m.nv;
  States s;
  Workspace ws(m);
  auto append = [&](std::vector<double>& out, int count, double scale) {
    const Eigen::VectorXd v = random_vector(rng, count, scale);
    out.insert(out.end(), v.data(), v.data() + count);
  };
  for (std::size_t k = 0; k < kStates; ++k) {
    append(s.q, nv, 2.0);
    append(s.qd, nv, 1.5);
    append(s.tau, nv, 8.0);
    append(s.qdd, nv, 3.0);
    append(s.fext, 6 * nv, 2.0);
    // a "cached" M^-1: taken at a nearby q and made slightly unsymmetric, so that a transposed
    // read of the row-major array would show
    const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(&s.q[k * nv], nv) + random_vector(rng, nv, 0.05);
    if (!minverse(m, ws, q)) throw std::runtime_error("minverse failed");
    const Eigen::MatrixXd noise = random_vector(rng, nv * nv, 1e-3).reshaped(nv, nv);
    const Eigen::MatrixXd minv = ws.Minv + noise.cwiseProduct(ws.Minv);
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nv; ++j) s.minv.push_back(minv(i, j));  // row-major
  }
  return s;
}

template <class S>
SlotT<S> to_slot(double x) {
  if constexpr (is_fixed_point_v<S>) return Q16_16(x).raw();
  else return static_cast<S>(x);
}
template <class S>
SlotT<S> slot_of(S x) {
  if constexpr (is_fixed_point_v<S>) return x.raw();
  else return x;
}
template <class S>
S from_slot(SlotT<S> r) {
  if constexpr (is_fixed_point_v<S>) return S::from_raw(r);
  else return r;
}

template <class S>
std::vector<SlotT<S>> to_slots(const std::vector<double>& x) {
  std::vector<SlotT<S>> out;
  for (double v : x) out.push_back(to_slot<S>(v));
  return out;
}

// The inputs of state k as the reference takes them, from the same arrays the plugin reads.
template <class S>
ReferenceInputs<S> reference_inputs(const BatchArrays<SlotT<S>>& a, std::size_t k, const OutputCase& c) {
  const auto nv = static_cast<Eigen::Index>(a.nv);
  ReferenceInputs<S> in;
  auto vec = [&](const std::vector<SlotT<S>>& src, Eigen::Index len) {
    VectorX<S> v(len);
    for (Eigen::Index i = 0; i < len; ++i) v(i) = from_slot<S>(src[k * len + i]);
    return v;
  };
  in.q = vec(a.q, nv);
  in.qd = vec(a.qd, nv);
  in.u = vec(a.u, nv);
  in.fext = vec(a.fext, 6 * nv);
  in.minv.resize(nv, nv);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (Eigen::Index j = 0; j < nv; ++j) in.minv(i, j) = from_slot<S>(a.minv[(k * nv + i) * nv + j]);
  in.with_fext = c.fext;
  in.with_minv = c.minv;
  return in;
}

struct Tally {
  int computed = 0, refused = 0;
};

template <class S>
void check_robot(const std::string& robot, Tally& tally) {
  using Raw = SlotT<S>;
  const Model model = robot_model(robot);
  const plugin::ModelDesc desc(model);
  const ModelTpl<S> ms = model.cast<S>();
  WorkspaceTpl<S> ws(ms);
  const rbdgrad_plugin_api* api = cpu_api();
  std::vector<InstancePtr> instances;
  for (int threads : kThreadCounts) {
    std::optional<PluginError> error;
    instances.push_back(create(api, desc.desc(), {{"threads", std::to_string(threads)}}, &error));
    ASSERT_FALSE(error) << error->message;
  }

  const States st = random_states(model, 1234);
  BatchArrays<Raw> a(kStates, model.nv);
  a.q = to_slots<S>(st.q);
  a.qd = to_slots<S>(st.qd);
  a.fext = to_slots<S>(st.fext);
  a.minv = to_slots<S>(st.minv);
  const std::size_t nv = a.nv;

  for (const std::uint32_t kind : {RBDGRAD_INPUT_TAU, RBDGRAD_INPUT_QDD}) {
    a.u = to_slots<S>(kind == RBDGRAD_INPUT_TAU ? st.tau : st.qdd);
    for (const OutputCase& c : every_case()) {
      const std::string what = robot + " " + scalar_name<S>() + " " + c.name +
                               (kind == RBDGRAD_INPUT_TAU ? ", tau input" : ", qdd input");
      // the core, called directly, one state after the other on one workspace
      std::vector<Status> ref_status(kStates);
      std::vector<std::map<std::uint32_t, MatrixX<S>>> ref(kStates);
      for (std::size_t k = 0; k < kStates; ++k)
        ref_status[k] = reference_state(ms, ws, reference_inputs<S>(a, k, c), kind == RBDGRAD_INPUT_TAU, c.outputs, ref[k]);
      std::size_t first_failed = kStates;
      for (std::size_t k = kStates; k-- > 0;)
        if (!ref_status[k]) first_failed = k;

      for (std::size_t t = 0; t < instances.size(); ++t) {
        const std::string where = what + ", " + std::to_string(kThreadCounts[t]) + " threads";
        for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1)
          std::fill(a.out(flag).begin(), a.out(flag).end(), Raw(77));
        std::fill(a.state_status.begin(), a.state_status.end(), -1);
        const rbdgrad_batch b = a.batch(plugin::precision_of<S>(), kind, c.outputs, c.minv, c.fext);
        const std::optional<PluginError> error = take(api, api->compute(instances[t].get(), &b));

        // the batch error names the first state the core refused, with the core's message
        if (first_failed == kStates) {
          EXPECT_FALSE(error) << where << ": " << error->message;
        } else {
          const Status& s = ref_status[first_failed];
          EXPECT_TRUE(error) << where;
          if (error) {
            EXPECT_EQ(error->code, plugin::error_code_from_status(s.code())) << where;
            const std::string expected = "state " + std::to_string(first_failed) + ": " + s.message();
            EXPECT_EQ(error->message.substr(0, expected.size()), expected) << where;
          }
        }
        for (std::size_t k = 0; k < kStates; ++k) {
          // a fixed-point state out of range is OUT_OF_RANGE, for the server's floating-point fallback
          const std::int32_t expected_status =
              ref_status[k] ? 0
                            : static_cast<std::int32_t>(
                                  plugin::state_error_code(ref_status[k].code(), plugin::precision_of<S>()));
          ASSERT_EQ(a.state_status[k], expected_status) << where << " state " << k << ": " << ref_status[k].message();
          if (t == 0) ++(ref_status[k] ? tally.computed : tally.refused);
          if (!ref_status[k]) continue;
          for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1) {
            const std::vector<Raw>& got = a.out(flag);
            const bool matrix = (flag & plugin::kMatrixOutputs) != 0;
            const std::size_t per = matrix ? nv * nv : nv;
            if (!(c.outputs & flag)) {
              // outputs that were not asked for stay untouched
              for (std::size_t i = 0; i < per; ++i) ASSERT_EQ(got[k * per + i], Raw(77)) << where << " " << plugin::output_name(flag);
              continue;
            }
            const MatrixX<S>& r = ref[k].at(flag);
            for (std::size_t i = 0; i < per; ++i) {
              const Raw expected = slot_of<S>(matrix ? r(i / nv, i % nv) : r(i, 0));  // row-major
              // bitwise: memcmp also tells -0.0 from 0.0
              ASSERT_EQ(std::memcmp(&got[k * per + i], &expected, sizeof(Raw)), 0)
                  << where << " state " << k << " " << plugin::output_name(flag) << " element " << i << ": plugin "
                  << +got[k * per + i] << ", core " << +expected;
            }
          }
        }
      }
    }
  }
}

class CpuConformance : public ::testing::TestWithParam<const char*> {};

TEST_P(CpuConformance, F64MatchesCoreBitwise) {
  Tally tally;
  check_robot<double>(GetParam(), tally);
  EXPECT_EQ(tally.refused, 0);
}

TEST_P(CpuConformance, F32MatchesCoreBitwise) {
  Tally tally;
  check_robot<float>(GetParam(), tally);
  EXPECT_EQ(tally.refused, 0);
}

TEST_P(CpuConformance, FixedPointMatchesCoreBitwise) {
  Tally tally;
  check_robot<Q16_16>(GetParam(), tally);
  // refusals (overflow) are compared too, but most states must compute for the check to mean much
  std::printf("%s fixed: %d state evaluations computed, %d refused\n", GetParam(), tally.computed, tally.refused);
  EXPECT_GE(tally.computed, 2 * tally.refused);
}

INSTANTIATE_TEST_SUITE_P(Robots, CpuConformance,
                         ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq", "random_tree"),
                         [](const auto& param_info) { return std::string(param_info.param); });

}  // namespace
}  // namespace rbdgrad::testing
