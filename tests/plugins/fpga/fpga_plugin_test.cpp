// Tests for the FPGA plugin (plugins/fpga/fpga_plugin.cpp) through the C ABI, loaded with dlopen as
// the daemon loads it: what it says it can do, why it is unavailable without a card, and, in
// emulation=csim, that a batch through the plugin (chunked, double-buffered) gives bit for bit
// what the kernel's top function gives each state, with out-of-range states flagged per state.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "common/model_desc.hpp"
#include "host/axi_packing.hpp"
#include "host/fpga_instance.hpp"
#include "host/latency_model.hpp"
#include "kernel/gradient_top.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using fpga::AxiLayout;
using fpga::DeviceWord;

constexpr std::uint32_t kGradient = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;

rbdgrad_plugin_entry_fn entry() {
  static const rbdgrad_plugin_entry_fn fn = load_plugin_entry(RBDGRAD_FPGA_PLUGIN_PATH);
  return fn;
}
const rbdgrad_plugin_api* api() { return entry()(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR); }

InstancePtr csim_instance(const plugin::ModelDesc& desc, const std::string& chunk = "64") {
  std::optional<PluginError> error;
  InstancePtr instance = create(api(), desc.desc(), {{"emulation", "csim"}, {"chunk_states", chunk}}, &error);
  EXPECT_FALSE(error) << error->message;
  return instance;
}

std::int32_t raw(double x) { return Q16_16(x).raw(); }

// The reference states of a robot as a Q16.16 batch (tau or qdd as u).
BatchArrays<std::int32_t> reference_batch(const std::string& robot, int nv, bool tau_input) {
  io::StateFile file;
  std::string error;
  EXPECT_TRUE(io::read_state_file(std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl", file, error))
      << error;
  BatchArrays<std::int32_t> a(file.states.size(), nv);
  for (std::size_t k = 0; k < file.states.size(); ++k)
    for (std::size_t i = 0; i < a.nv; ++i) {
      a.q[k * a.nv + i] = raw(file.states[k].at("q")[i]);
      a.qd[k * a.nv + i] = raw(file.states[k].at("qd")[i]);
      a.u[k * a.nv + i] = raw(file.states[k].at(tau_input ? "tau" : "qdd")[i]);
    }
  return a;
}

// What the kernel's top function gives state k of `a` alone, packed as the host packs it
// (M^-1 by the core library in double): the output words, or empty when the host refuses it.
std::vector<DeviceWord> expected_words(const Model& model, const BatchArrays<std::int32_t>& a, std::size_t k,
                                       bool tau_input) {
  const int nv = model.nv;
  std::vector<double> q(a.nv), qd(a.nv), u(a.nv), minv(a.nv * a.nv);
  auto value = [](std::int32_t r) { return Q16_16::from_raw(r).to_double(); };
  for (std::size_t i = 0; i < a.nv; ++i) {
    q[i] = value(a.q[k * a.nv + i]);
    qd[i] = value(a.qd[k * a.nv + i]);
    u[i] = value(a.u[k * a.nv + i]);
  }
  WorkspaceTpl<double> ws(model);
  EXPECT_TRUE(minverse(model, ws, Eigen::Map<const Eigen::VectorXd>(q.data(), nv)));
  for (std::size_t r = 0; r < a.nv; ++r)
    for (std::size_t c = 0; c < a.nv; ++c) minv[r * a.nv + c] = ws.Minv(static_cast<int>(r), static_cast<int>(c));
  std::vector<DeviceWord> robot, in;
  std::string error;
  EXPECT_TRUE(fpga::pack_robot(model, robot, error)) << error;
  if (!fpga::pack_state(nv, q.data(), qd.data(), u.data(), minv.data(), in, error)) return {};
  std::vector<DeviceWord> out(static_cast<std::size_t>(AxiLayout::out_words(nv)), -1);
  rbdgrad_fpga_gradient(robot.data(), in.data(), out.data(), 1, tau_input ? 1 : 0);
  return out;
}

TEST(FpgaPluginInfo, DescribesAFixedPointGradientBackend) {
  rbdgrad_plugin_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->get_info(&info)));
  EXPECT_STREQ(info.name, "fpga");
  EXPECT_EQ(info.precisions, static_cast<std::uint32_t>(RBDGRAD_PRECISION_FIXED_Q16_16));
  EXPECT_EQ(info.outputs, fpga::kFpgaOutputs);
  EXPECT_EQ(info.max_nv, static_cast<std::uint32_t>(fpga::kDeviceMaxNv));
  EXPECT_NE(api()->describe_instance, nullptr);
}

TEST(FpgaPluginCanRun, FixedPointGradientsOnly) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  EXPECT_FALSE(take(api(), api()->can_run(&desc.desc(), RBDGRAD_PRECISION_FIXED_Q16_16, kGradient, 5)));
  auto e = take(api(), api()->can_run(&desc.desc(), RBDGRAD_PRECISION_F64, kGradient, 5));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED);
  e = take(api(), api()->can_run(&desc.desc(), RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_OUTPUT_DTAU_DQ, 5));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED);
}

TEST(FpgaPluginCreate, WithoutACardOrEmulationItIsUnavailableAndSaysWhy) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  std::optional<PluginError> e;
  EXPECT_FALSE(create(api(), desc.desc(), {}, &e));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE);
  EXPECT_THAT(e->message, HasSubstr("xclbin"));
  EXPECT_THAT(e->message, HasSubstr("emulation: csim"));
}

TEST(FpgaPluginCreate, BadOptionsNameTheOption) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  std::optional<PluginError> e;
  EXPECT_FALSE(create(api(), desc.desc(), {{"emulation", "hw_emu"}}, &e));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(e->message, HasSubstr("'emulation'"));
  EXPECT_FALSE(create(api(), desc.desc(), {{"emulation", "csim"}, {"chunk_states", "0"}}, &e));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("'chunk_states'"));
  EXPECT_FALSE(create(api(), desc.desc(), {{"emulation", "csim"}, {"bogus", "1"}}, &e));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
}

#ifdef RBDGRAD_HAVE_XRT
// A bad xclbin is refused before XRT reads it (XRT crashes or hangs on some malformed files).
TEST(FpgaPluginCreate, MissingOrMalformedXclbinIsUnavailableBeforeXrtReadsIt) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  std::optional<PluginError> e;
  EXPECT_FALSE(create(api(), desc.desc(), {{"xclbin", "/nonexistent/rbdgrad.xclbin"}}, &e));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE);
  EXPECT_THAT(e->message, HasSubstr("cannot be read"));

  const std::string path = ::testing::TempDir() + "/empty.xclbin";
  for (const std::string& content : {std::string(), std::string("xclbin2\0", 8), std::string(600, 'x')}) {
    std::ofstream(path, std::ios::binary) << content;
    EXPECT_FALSE(create(api(), desc.desc(), {{"xclbin", path}}, &e)) << content.size();
    ASSERT_TRUE(e);
    EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE);
    EXPECT_THAT(e->message, HasSubstr("xclbin '" + path + "'"));
  }
  std::remove(path.c_str());
}
#endif

TEST(FpgaPluginCreate, CsimSaysSoInItsDescription) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  InstancePtr instance = csim_instance(desc);
  ASSERT_TRUE(instance);
  rbdgrad_instance_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->describe_instance(instance.get(), &info)));
  EXPECT_STREQ(info.mode, "csim");
  EXPECT_THAT(info.device, HasSubstr("C simulation"));
}

// The cycle model through the ABI (1.2 estimate_latency): what the card would take, also in csim.
TEST(FpgaPluginEstimate, TheCycleModelOfABatch) {
  const Model model = load_embedded("iiwa14");
  const plugin::ModelDesc desc(model);
  InstancePtr instance = csim_instance(desc);
  ASSERT_TRUE(instance);
  ASSERT_NE(api()->estimate_latency, nullptr);
  for (const std::uint64_t n : {1u, 16u, 1000u}) {
    double us = -1;
    ASSERT_FALSE(take(api(), api()->estimate_latency(instance.get(), RBDGRAD_PRECISION_FIXED_Q16_16,
                                                     RBDGRAD_INPUT_TAU, n, &us)));
    fpga::LatencyEstimate e;
    ASSERT_TRUE(fpga::estimate_latency(model, fpga::KernelTiming{}, n, fpga::InputKind::kTau, e));
    EXPECT_DOUBLE_EQ(us, e.batch_us) << n;
  }
  double us = 0;
  std::optional<PluginError> e = take(api(), api()->estimate_latency(instance.get(), RBDGRAD_PRECISION_F64,
                                                                     RBDGRAD_INPUT_TAU, 16, &us));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED) << e->message;
  e = take(api(), api()->estimate_latency(instance.get(), RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, 0, &us));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
}

// A scene's plan sets the columns the cycle model counts: one derivative runs fewer column passes
// and is predicted cheaper than the whole gradient, qdd alone cheaper still; without a plan, both.
TEST(FpgaPluginEstimate, AScenesColumnsAreTheOnesPredicted) {
  const Model model = load_embedded("iiwa14");
  const std::pair<std::uint32_t, unsigned> plans[] = {
      {RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ, fpga::kColumnsDq},
      {RBDGRAD_OUTPUT_DQDD_DQD | RBDGRAD_OUTPUT_MINV, fpga::kColumnsDqd},
      {kGradient, fpga::kAllColumns},
      {RBDGRAD_OUTPUT_QDD, 0u}};
  double full_us = 0;
  ASSERT_FALSE(take(api(), api()->estimate_latency(csim_instance(plugin::ModelDesc(model)).get(),
                                                   RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, 64, &full_us)));
  for (const auto& [outputs, columns] : plans) {
    plugin::ModelDesc desc(model);
    desc.set_plan(outputs, false, {});
    InstancePtr scene = csim_instance(desc);
    ASSERT_TRUE(scene);
    for (const std::uint32_t input : {RBDGRAD_INPUT_TAU, RBDGRAD_INPUT_QDD}) {
      double us = -1;
      ASSERT_FALSE(take(api(), api()->estimate_latency(scene.get(), RBDGRAD_PRECISION_FIXED_Q16_16, input, 64, &us)));
      fpga::LatencyEstimate e;
      ASSERT_TRUE(fpga::estimate_latency(
          model, fpga::KernelTiming{}, 64, input == RBDGRAD_INPUT_TAU ? fpga::InputKind::kTau : fpga::InputKind::kQdd,
          columns, e));
      EXPECT_DOUBLE_EQ(us, e.batch_us) << outputs;
      if (input == RBDGRAD_INPUT_TAU && columns == fpga::kAllColumns) {
        EXPECT_DOUBLE_EQ(us, full_us);
      }
      if (input == RBDGRAD_INPUT_TAU && columns != fpga::kAllColumns) {
        EXPECT_LT(us, full_us) << outputs;
      }
    }
  }
}

// Every robot, both inputs, several chunk sizes (one state per run, a remainder, one run): each
// state's words are the top function's for that state alone; unrequested outputs stay untouched.
TEST(FpgaPluginCompute, BatchesEqualTheTopFunctionStateByStateInEveryChunking) {
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) {
    const Model model = load_embedded(robot);
    const plugin::ModelDesc desc(model);
    for (bool tau_input : {false, true}) {
      const BatchArrays<std::int32_t> reference = reference_batch(robot, model.nv, tau_input);
      std::vector<std::vector<DeviceWord>> expected;
      for (std::size_t k = 0; k < reference.n; ++k) expected.push_back(expected_words(model, reference, k, tau_input));
      for (const char* chunk : {"1", "3", "64"}) {
        SCOPED_TRACE(std::string(robot) + (tau_input ? " tau" : " qdd") + " chunk " + chunk);
        InstancePtr instance = csim_instance(desc, chunk);
        BatchArrays<std::int32_t> a = reference;
        rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, tau_input ? RBDGRAD_INPUT_TAU : RBDGRAD_INPUT_QDD,
                                  kGradient, false, false);
        const auto error = take(api(), api()->compute(instance.get(), &b));
        const std::size_t n1 = a.nv;
        int flagged = 0;
        for (std::size_t k = 0; k < a.n; ++k) {
          const std::vector<DeviceWord>& w = expected[k];
          const bool kernel_ok = !w.empty() && w.back() == fpga::kStatusOk;
          if (!kernel_ok) {
            ++flagged;
            EXPECT_EQ(a.state_status[k], RBDGRAD_ERROR_OUT_OF_RANGE) << "state " << k;
            continue;
          }
          ASSERT_EQ(a.state_status[k], RBDGRAD_OK) << "state " << k;
          for (std::size_t i = 0; i < n1; ++i) ASSERT_EQ(a.out(RBDGRAD_OUTPUT_QDD)[k * n1 + i], w[i]) << k;
          for (std::size_t e = 0; e < n1 * n1; ++e) {
            ASSERT_EQ(a.out(RBDGRAD_OUTPUT_DQDD_DQ)[k * n1 * n1 + e], w[n1 + e]) << k;
            ASSERT_EQ(a.out(RBDGRAD_OUTPUT_DQDD_DQD)[k * n1 * n1 + e], w[n1 + n1 * n1 + e]) << k;
          }
        }
        // the error names the first flagged state, and only when there is one
        EXPECT_EQ(error.has_value(), flagged > 0);
        if (error) {
          EXPECT_EQ(error->code, RBDGRAD_ERROR_NUMERICAL);
        }
        // iiwa14's light last joint: six reference states leave Q16.16 (docs/fpga.md); the
        // other robots stay in range
        if (std::string(robot) != "iiwa14") {
          EXPECT_EQ(flagged, 0);
        }
        for (std::uint32_t flag : {RBDGRAD_OUTPUT_MINV, RBDGRAD_OUTPUT_TAU, RBDGRAD_OUTPUT_M})
          for (std::int32_t x : a.out(flag)) ASSERT_EQ(x, 77) << "unrequested output " << flag << " was written";
      }
    }
  }
}

// A scene that needs d qdd/d q only (issue 8, a plan with that output): the d/dqd datapaths are
// bypassed, and what is computed equals the full batch's bits.
TEST(FpgaPluginCompute, AScenesSkippedColumnsAreBypassed) {
  const Model model = load_embedded("hyq");
  plugin::ModelDesc desc(model);
  desc.set_plan(RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ, false, {});
  InstancePtr scene = csim_instance(desc);
  ASSERT_TRUE(scene);
  InstancePtr full = csim_instance(plugin::ModelDesc(model));
  ASSERT_TRUE(full);
  const BatchArrays<std::int32_t> reference = reference_batch("hyq", model.nv, true);
  BatchArrays<std::int32_t> a = reference, b = reference;
  rbdgrad_batch only_dq = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU,
                                  RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ, false, false);
  ASSERT_FALSE(take(api(), api()->compute(scene.get(), &only_dq)));
  rbdgrad_batch everything = b.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, kGradient, false, false);
  ASSERT_FALSE(take(api(), api()->compute(full.get(), &everything)));
  EXPECT_EQ(a.out(RBDGRAD_OUTPUT_QDD), b.out(RBDGRAD_OUTPUT_QDD));
  EXPECT_EQ(a.out(RBDGRAD_OUTPUT_DQDD_DQ), b.out(RBDGRAD_OUTPUT_DQDD_DQ));
  for (std::int32_t x : a.out(RBDGRAD_OUTPUT_DQDD_DQD)) ASSERT_EQ(x, 77) << "the bypassed output was written";
  // outside the plan
  rbdgrad_batch outside = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, kGradient, false, false);
  const auto e = take(api(), api()->compute(scene.get(), &outside));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("outside the instance's plan"));
}

// States built to overflow (300 rad/s on every joint) are flagged alone; the MINV output is the
// core's M^-1 rounded to Q16.16, and a caller's M^-1 is used.
TEST(FpgaPluginCompute, OverflowIsFlaggedPerStateAndMinvIsTheHosts) {
  const Model model = load_embedded("panda");
  const plugin::ModelDesc desc(model);
  InstancePtr instance = csim_instance(desc, "2");
  BatchArrays<std::int32_t> a = reference_batch("panda", model.nv, false);
  const std::size_t n1 = a.nv;
  for (std::size_t i = 0; i < n1; ++i) a.qd[1 * n1 + i] = raw(300.0);
  rbdgrad_batch b =
      a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient | RBDGRAD_OUTPUT_MINV, false, false);
  const auto e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, StartsWith("state 1: "));
  EXPECT_THAT(e->message, HasSubstr("Q16.16"));
  for (std::size_t k = 0; k < a.n; ++k)
    EXPECT_EQ(a.state_status[k], k == 1 ? RBDGRAD_ERROR_OUT_OF_RANGE : RBDGRAD_OK) << k;

  WorkspaceTpl<double> ws(model);
  Eigen::VectorXd q(model.nv);
  for (int i = 0; i < model.nv; ++i) q(i) = Q16_16::from_raw(a.q[static_cast<std::size_t>(i)]).to_double();
  ASSERT_TRUE(minverse(model, ws, q));
  for (std::size_t r = 0; r < n1; ++r)
    for (std::size_t c = 0; c < n1; ++c)
      EXPECT_EQ(a.out(RBDGRAD_OUTPUT_MINV)[r * n1 + c], raw(ws.Minv(static_cast<int>(r), static_cast<int>(c))));

  // a caller's M^-1 goes to the kernel as it comes: the host's own rounded gives the same bits as
  // none, twice it gives twice the derivatives (up to rounding)
  BatchArrays<std::int32_t> own = reference_batch("panda", model.nv, false);
  BatchArrays<std::int32_t> twice = own, none = own;
  own.minv.assign(a.out(RBDGRAD_OUTPUT_MINV).begin(), a.out(RBDGRAD_OUTPUT_MINV).end());
  own.minv.resize(own.n * n1 * n1);
  twice.minv.resize(own.n * n1 * n1);
  for (std::size_t k = 0; k < own.n; ++k) {
    // every state gets state 0's M^-1 (the test only looks at state 0)
    std::copy_n(a.out(RBDGRAD_OUTPUT_MINV).begin(), n1 * n1, own.minv.begin() + static_cast<long>(k * n1 * n1));
  }
  for (std::size_t e2 = 0; e2 < twice.minv.size(); ++e2) twice.minv[e2] = 2 * own.minv[e2];
  rbdgrad_batch b_none = none.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient, false, false);
  rbdgrad_batch b_own = own.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient, true, false);
  rbdgrad_batch b_twice = twice.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient, true, false);
  EXPECT_FALSE(take(api(), api()->compute(instance.get(), &b_none)));
  static_cast<void>(take(api(), api()->compute(instance.get(), &b_own)));
  static_cast<void>(take(api(), api()->compute(instance.get(), &b_twice)));
  ASSERT_EQ(own.state_status[0], RBDGRAD_OK);
  ASSERT_EQ(twice.state_status[0], RBDGRAD_OK);
  for (std::size_t e2 = 0; e2 < n1 * n1; ++e2) {
    const std::int32_t x = none.out(RBDGRAD_OUTPUT_DQDD_DQ)[e2];
    EXPECT_EQ(own.out(RBDGRAD_OUTPUT_DQDD_DQ)[e2], x) << e2;
    EXPECT_NEAR(twice.out(RBDGRAD_OUTPUT_DQDD_DQ)[e2], 2 * x, 4) << e2;  // raw units: a few LSB
  }
}

TEST(FpgaPluginCompute, ExternalForcesAreUnsupportedAndOldHostsGetNumerical) {
  const Model model = load_embedded("panda");
  const plugin::ModelDesc desc(model);
  InstancePtr instance = csim_instance(desc);
  BatchArrays<std::int32_t> a = reference_batch("panda", model.nv, false);
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient, false, true);
  auto e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED);
  EXPECT_THAT(e->message, HasSubstr("fext"));

  // a host of API 1.0 does not know OUT_OF_RANGE: it gets NUMERICAL (api() would say 1.1 again)
  const rbdgrad_plugin_api* old_host = entry()(RBDGRAD_PLUGIN_API_MAJOR, 0);
  ASSERT_NE(old_host, nullptr);
  for (std::size_t i = 0; i < a.nv; ++i) a.qd[i] = raw(300.0);
  b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD, kGradient, false, false);
  e = take(old_host, old_host->compute(instance.get(), &b));
  EXPECT_EQ(a.state_status[0], RBDGRAD_ERROR_NUMERICAL);
  const rbdgrad_plugin_api* new_host = api();
  e = take(new_host, new_host->compute(instance.get(), &b));
  EXPECT_EQ(a.state_status[0], RBDGRAD_ERROR_OUT_OF_RANGE);
}

}  // namespace
}  // namespace rbdgrad::testing
