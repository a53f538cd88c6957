// Tests for plugins/cpu/cpu_plugin.cpp through the C ABI (librbdgrad_cpu.so loaded with dlopen):
// version negotiation, get_info, can_run, options, batch validation and per-state failures.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>

#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "common/model_desc.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

rbdgrad_plugin_entry_fn entry() {
  static const rbdgrad_plugin_entry_fn fn = load_plugin_entry(RBDGRAD_CPU_PLUGIN_PATH);
  return fn;
}

const rbdgrad_plugin_api* api() { return entry()(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR); }

const plugin::ModelDesc& iiwa() {
  static const plugin::ModelDesc desc(load_embedded("iiwa14"));
  return desc;
}

InstancePtr make_instance(const std::vector<std::pair<std::string, std::string>>& options = {{"threads", "2"}}) {
  std::optional<PluginError> error;
  InstancePtr instance = create(api(), iiwa().desc(), options, &error);
  EXPECT_FALSE(error) << error->message;
  return instance;
}

// n random f64 states of iiwa14 with tau input
BatchArrays<double> random_batch(std::size_t n, unsigned seed) {
  const int nv = static_cast<int>(iiwa().desc().nv);
  BatchArrays<double> a(n, nv);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (std::vector<double>* v : {&a.q, &a.qd, &a.u})
    for (double& x : *v) x = 2 * u(rng);
  return a;
}

TEST(CpuPluginVersion, EntryRefusesAnotherMajorAndAcceptsANewerMinor) {
  EXPECT_EQ(entry()(RBDGRAD_PLUGIN_API_MAJOR + 1, 0), nullptr);
  EXPECT_EQ(entry()(RBDGRAD_PLUGIN_API_MAJOR - 1, RBDGRAD_PLUGIN_API_MINOR), nullptr);
  const rbdgrad_plugin_api* table = entry()(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  ASSERT_NE(table, nullptr);
  EXPECT_EQ(table->struct_size, sizeof(rbdgrad_plugin_api));
  EXPECT_EQ(table->api_major, static_cast<std::uint32_t>(RBDGRAD_PLUGIN_API_MAJOR));
  EXPECT_EQ(table->api_minor, static_cast<std::uint32_t>(RBDGRAD_PLUGIN_API_MINOR));
  // a host that knows more (higher minor) gets the same table
  EXPECT_EQ(entry()(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR + 3), table);
}

TEST(CpuPluginInfo, DescribesTheCpuBackend) {
  rbdgrad_plugin_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->get_info(&info)));
  EXPECT_STREQ(info.name, "cpu");
  EXPECT_NE(info.version, nullptr);
  EXPECT_EQ(info.precisions, static_cast<std::uint32_t>(RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32 |
                                                       RBDGRAD_PRECISION_FIXED_Q16_16));
  EXPECT_EQ(info.outputs, 255u);
  EXPECT_EQ(info.max_batch, 0u);
  EXPECT_EQ(info.max_nv, 0u);

  info.struct_size = sizeof(info) - 1;
  const auto e = take(api(), api()->get_info(&info));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(e->message, HasSubstr("struct_size"));
  EXPECT_EQ(take(api(), api()->get_info(nullptr))->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
}

TEST(CpuPluginCanRun, ChecksPrecisionAndOutputs) {
  const rbdgrad_model_desc& d = iiwa().desc();
  EXPECT_FALSE(take(api(), api()->can_run(&d, RBDGRAD_PRECISION_FIXED_Q16_16, 255, 1000)));
  auto e = take(api(), api()->can_run(&d, 8, RBDGRAD_OUTPUT_QDD, 1));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(e->message, HasSubstr("precision"));
  e = take(api(), api()->can_run(&d, RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32, RBDGRAD_OUTPUT_QDD, 1));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("precision"));
  e = take(api(), api()->can_run(&d, RBDGRAD_PRECISION_F64, 0, 1));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("outputs"));
  e = take(api(), api()->can_run(&d, RBDGRAD_PRECISION_F64, 256, 1));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("outputs"));
  EXPECT_TRUE(take(api(), api()->can_run(nullptr, RBDGRAD_PRECISION_F64, 1, 1)));
}

TEST(CpuPluginOptions, BadThreadsValueNamesTheOption) {
  for (const char* bad : {"abc", "0", "-1", "", "4x", "99999", " 2"}) {
    std::optional<PluginError> error;
    InstancePtr instance = create(api(), iiwa().desc(), {{"threads", bad}}, &error);
    EXPECT_EQ(instance, nullptr) << bad;
    ASSERT_TRUE(error) << bad;
    EXPECT_EQ(error->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << bad;
    EXPECT_THAT(error->message, HasSubstr("option 'threads'")) << bad;
  }
}

TEST(CpuPluginOptions, IdlePollIsAnOptionWithARange) {
  for (const char* good : {"0", "1", "1000000"}) {
    std::optional<PluginError> error;
    EXPECT_NE(create(api(), iiwa().desc(), {{"threads", "2"}, {"idle_poll_us", good}}, &error), nullptr) << good;
  }
  for (const char* bad : {"abc", "-1", "1000001", ""}) {
    std::optional<PluginError> error;
    EXPECT_EQ(create(api(), iiwa().desc(), {{"idle_poll_us", bad}}, &error), nullptr) << bad;
    ASSERT_TRUE(error) << bad;
    EXPECT_THAT(error->message, HasSubstr("option 'idle_poll_us'")) << bad;
  }
}

TEST(CpuPluginOptions, UnknownOrRepeatedKeysAreErrors) {
  std::optional<PluginError> error;
  create(api(), iiwa().desc(), {{"thread", "2"}}, &error);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(error->message, HasSubstr("unknown option 'thread'"));
  create(api(), iiwa().desc(), {{"threads", "2"}, {"threads", "3"}}, &error);
  ASSERT_TRUE(error);
  EXPECT_THAT(error->message, HasSubstr("twice"));
}

TEST(CpuPluginOptions, NoOptionsAndNullOptionsUseTheDefault) {
  EXPECT_NE(make_instance({}), nullptr);
  rbdgrad_instance* instance = nullptr;
  ASSERT_FALSE(take(api(), api()->create_instance(&iiwa().desc(), nullptr, &instance)));
  ASSERT_NE(instance, nullptr);
  api()->destroy_instance(instance);
  api()->destroy_instance(nullptr);  // a no-op
}

TEST(CpuPluginCreate, InvalidModelIsRejectedWithTheField) {
  const Model m = load_embedded("iiwa14");
  plugin::ModelDesc desc(m);
  rbdgrad_model_desc bad = desc.desc();
  std::vector<double> mass(bad.mass, bad.mass + bad.nv);
  mass[3] = std::nan("");
  bad.mass = mass.data();
  std::optional<PluginError> error;
  EXPECT_EQ(create(api(), bad, {}, &error), nullptr);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(error->message, HasSubstr("model_desc.mass[3] (joint 3)"));

  rbdgrad_instance* instance = reinterpret_cast<rbdgrad_instance*>(&error);  // must be reset to NULL
  auto e = take(api(), api()->create_instance(nullptr, nullptr, &instance));
  ASSERT_TRUE(e);
  EXPECT_EQ(instance, nullptr);
  EXPECT_TRUE(take(api(), api()->create_instance(&desc.desc(), nullptr, nullptr)));
}

// One bad field per case: the right code and a message that names the field.
TEST(CpuPluginCompute, BadBatchNamesTheField) {
  InstancePtr instance = make_instance();
  BatchArrays<double> a = random_batch(4, 1);
  struct Bad {
    const char* field;
    rbdgrad_error_code code;
    void (*spoil)(rbdgrad_batch&);
  };
  const Bad cases[] = {
      {"batch.q", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.q = nullptr; }},
      {"batch.qd", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.qd = nullptr; }},
      {"batch.u", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.u = nullptr; }},
      {"batch.n", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.n = 0; }},
      {"batch.precision", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.precision = 16; }},
      {"batch.precision", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.precision = 0; }},
      {"batch.outputs", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.outputs = 0; }},
      {"batch.outputs", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.outputs = 1u << 9; }},
      {"batch.input_kind", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.input_kind = 2; }},
      {"batch.struct_size", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.struct_size = 8; }},
      {"batch.dtau_dq", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.dtau_dq = nullptr; }},
      {"batch.minv_out", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.minv_out = nullptr; }},
      {"batch.q", RBDGRAD_ERROR_INVALID_ARGUMENT,
       [](rbdgrad_batch& b) { b.q = static_cast<const char*>(b.q) + 1; }},  // misaligned
      {"batch.n", RBDGRAD_ERROR_INVALID_ARGUMENT, [](rbdgrad_batch& b) { b.n = std::numeric_limits<std::uint64_t>::max() / 8; }},
  };
  for (const Bad& c : cases) {
    rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, 255, false, false);
    c.spoil(b);
    const auto e = take(api(), api()->compute(instance.get(), &b));
    ASSERT_TRUE(e) << c.field;
    EXPECT_EQ(e->code, c.code) << c.field << ": " << e->message;
    EXPECT_THAT(e->message, StartsWith(c.field)) << c.field;
  }
  EXPECT_EQ(take(api(), api()->compute(instance.get(), nullptr))->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, 255, false, false);
  EXPECT_EQ(take(api(), api()->compute(nullptr, &b))->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  // unused outputs may be NULL, and M alone needs neither qd nor u
  rbdgrad_batch m_only = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_M, false, false);
  m_only.qd = m_only.u = nullptr;
  m_only.qdd = m_only.tau = m_only.dtau_dq = nullptr;
  m_only.state_status = nullptr;
  EXPECT_FALSE(take(api(), api()->compute(instance.get(), &m_only)));
  // with qdd as the input kind too (the input is then not read either)
  m_only.input_kind = RBDGRAD_INPUT_QDD;
  EXPECT_FALSE(take(api(), api()->compute(instance.get(), &m_only)));
}

// A NaN in one state fails that state only: the others are computed exactly as without it.
template <class Raw>
void check_nan_state(std::uint32_t precision, const std::vector<std::size_t>& nan_states, int threads) {
  InstancePtr instance = make_instance({{"threads", std::to_string(threads)}});
  const BatchArrays<double> source = random_batch(9, 7);
  BatchArrays<Raw> clean(9, static_cast<int>(source.nv)), dirty = clean;
  for (std::size_t i = 0; i < source.q.size(); ++i) {
    clean.q[i] = static_cast<Raw>(source.q[i]);
    clean.qd[i] = static_cast<Raw>(source.qd[i]);
    clean.u[i] = static_cast<Raw>(source.u[i]);
  }
  dirty.q = clean.q;
  dirty.qd = clean.qd;
  dirty.u = clean.u;
  for (std::size_t k : nan_states) dirty.q[k * source.nv + 2] = std::numeric_limits<Raw>::quiet_NaN();

  rbdgrad_batch b = clean.batch(precision, RBDGRAD_INPUT_TAU, 255, false, false);
  ASSERT_FALSE(take(api(), api()->compute(instance.get(), &b)));
  b = dirty.batch(precision, RBDGRAD_INPUT_TAU, 255, false, false);
  const auto e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_NUMERICAL);
  // the core reports the NaN where it first shows (a non-finite result, or M not positive definite)
  const std::size_t first = *std::min_element(nan_states.begin(), nan_states.end());
  EXPECT_THAT(e->message, StartsWith("state " + std::to_string(first) + ": "));
  if (nan_states.size() > 1) {
    EXPECT_THAT(e->message, HasSubstr("and " + std::to_string(nan_states.size() - 1) + " more failed states"));
  }
  for (std::size_t k = 0; k < 9; ++k) {
    const bool bad = std::find(nan_states.begin(), nan_states.end(), k) != nan_states.end();
    EXPECT_EQ(dirty.state_status[k], bad ? RBDGRAD_ERROR_NUMERICAL : 0) << k;
    if (bad) continue;
    for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1) {
      const std::size_t per = dirty.out(flag).size() / 9;
      for (std::size_t i = 0; i < per; ++i)
        ASSERT_EQ(dirty.out(flag)[k * per + i], clean.out(flag)[k * per + i]) << "state " << k << " " << plugin::output_name(flag);
    }
  }
}

TEST(CpuPluginCompute, NanStateFailsAloneF64) {
  check_nan_state<double>(RBDGRAD_PRECISION_F64, {3}, 1);
  check_nan_state<double>(RBDGRAD_PRECISION_F64, {3}, 4);
  check_nan_state<double>(RBDGRAD_PRECISION_F64, {5, 2}, 4);
}

TEST(CpuPluginCompute, NanStateFailsAloneF32) {
  check_nan_state<float>(RBDGRAD_PRECISION_F32, {3}, 2);
  check_nan_state<float>(RBDGRAD_PRECISION_F32, {0, 8}, 3);
}

TEST(CpuPluginCompute, InfiniteInputAndSaturatedFixedPointFailTheirState) {
  InstancePtr instance = make_instance({{"threads", "2"}});
  BatchArrays<double> a = random_batch(3, 3);
  a.qd[1 * a.nv] = std::numeric_limits<double>::infinity();
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_QDD, 255, false, false);
  auto e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, StartsWith("state 1: "));
  EXPECT_EQ(a.state_status[0], 0);
  EXPECT_EQ(a.state_status[1], RBDGRAD_ERROR_NUMERICAL);
  EXPECT_EQ(a.state_status[2], 0);

  // Q16.16: the largest raw velocities overflow the products; the state is refused, not wrapped
  BatchArrays<std::int32_t> f(3, static_cast<int>(a.nv));
  for (std::size_t i = 0; i < f.qd.size(); ++i) f.qd[i] = i < a.nv ? std::numeric_limits<std::int32_t>::max() : 1 << 14;
  b = f.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, 255, false, false);
  e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_NUMERICAL);
  EXPECT_THAT(e->message, StartsWith("state 0: "));
  EXPECT_THAT(e->message, HasSubstr("overflow"));
  // a fixed-point state out of range: the host may compute it again in floating point
  EXPECT_EQ(f.state_status[0], RBDGRAD_ERROR_OUT_OF_RANGE);
  EXPECT_EQ(f.state_status[1], 0);
  EXPECT_EQ(f.state_status[2], 0);
}

TEST(CpuPluginCompute, ManyMoreStatesThanThreadsAndRepeatedCalls) {
  InstancePtr instance = make_instance({{"threads", "3"}});
  BatchArrays<double> a = random_batch(1000, 11);
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_M, false, false);
  ASSERT_FALSE(take(api(), api()->compute(instance.get(), &b)));
  const std::vector<double> first = a.out(RBDGRAD_OUTPUT_QDD);
  for (int round = 0; round < 5; ++round) {
    std::fill(a.out(RBDGRAD_OUTPUT_QDD).begin(), a.out(RBDGRAD_OUTPUT_QDD).end(), 0.0);
    ASSERT_FALSE(take(api(), api()->compute(instance.get(), &b)));
    ASSERT_EQ(a.out(RBDGRAD_OUTPUT_QDD), first);
  }
  for (std::int32_t s : a.state_status) ASSERT_EQ(s, 0);
}

TEST(CpuPluginCompute, InstancesComputeConcurrently) {
  // the ABI allows concurrent compute on different instances
  InstancePtr one = make_instance({{"threads", "2"}}), two = make_instance({{"threads", "2"}});
  BatchArrays<double> a = random_batch(200, 5), c = a;
  rbdgrad_batch ba = a.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, 255, false, false);
  rbdgrad_batch bc = c.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, 255, false, false);
  std::optional<PluginError> ea, ec;
  std::thread other([&] { ec = take(api(), api()->compute(two.get(), &bc)); });
  ea = take(api(), api()->compute(one.get(), &ba));
  other.join();
  EXPECT_FALSE(ea);
  EXPECT_FALSE(ec);
  for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1) EXPECT_EQ(a.out(flag), c.out(flag));
}

// A scene's plan (ABI 1.3): forces are read on its bodies only, and batches outside it are refused.
TEST(CpuPluginPlan, ReadsForcesOnThePlansBodiesOnly) {
  constexpr std::uint32_t kGradient = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  plugin::ModelDesc with_plan(load_embedded("iiwa14"));
  with_plan.set_plan(kGradient, false, {1, 4});
  std::optional<PluginError> error;
  InstancePtr planned = create(api(), with_plan.desc(), {{"threads", "2"}}, &error);
  ASSERT_TRUE(planned) << error->message;
  InstancePtr plain = make_instance();

  BatchArrays<double> everywhere = random_batch(5, 21);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5, 5);
  for (double& f : everywhere.fext) f = u(rng);
  BatchArrays<double> on_bodies = everywhere;  // the same forces on bodies 1 and 4, none elsewhere
  for (std::size_t k = 0; k < 5; ++k)
    for (std::size_t body = 0; body < 7; ++body)
      if (body != 1 && body != 4)
        for (std::size_t c = 0; c < 6; ++c) on_bodies.fext[(k * 7 + body) * 6 + c] = 0;

  rbdgrad_batch b = everywhere.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, kGradient, false, true);
  ASSERT_FALSE(take(api(), api()->compute(planned.get(), &b)));
  BatchArrays<double> reference = on_bodies, unplanned = everywhere;
  b = reference.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, kGradient, false, true);
  ASSERT_FALSE(take(api(), api()->compute(plain.get(), &b)));
  b = unplanned.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, kGradient, false, true);
  ASSERT_FALSE(take(api(), api()->compute(plain.get(), &b)));
  for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_DQDD_DQ, RBDGRAD_OUTPUT_DQDD_DQD})
    EXPECT_EQ(everywhere.out(flag), reference.out(flag)) << plugin::output_name(flag);
  // (d qdd/d qd does not depend on the forces)
  for (const std::uint32_t flag : {RBDGRAD_OUTPUT_QDD, RBDGRAD_OUTPUT_DQDD_DQ})
    EXPECT_NE(unplanned.out(flag), reference.out(flag)) << plugin::output_name(flag) << ": the other forces matter";

  // outside the plan: another output, a caller's M^-1
  b = everywhere.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, kGradient | RBDGRAD_OUTPUT_MINV, false, true);
  auto e = take(api(), api()->compute(planned.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(e->message, HasSubstr("outside the instance's plan"));
  b = everywhere.batch(RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU, kGradient, true, true);
  e = take(api(), api()->compute(planned.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_THAT(e->message, HasSubstr("batch.minv is set"));
}

TEST(CpuPluginPlan, ABadPlanIsRefusedAtCreation) {
  plugin::ModelDesc desc(load_embedded("iiwa14"));
  desc.set_plan(RBDGRAD_OUTPUT_DQDD_DQ, false, {3, 9});
  std::optional<PluginError> error;
  EXPECT_FALSE(create(api(), desc.desc(), {}, &error));
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(error->message, HasSubstr("model_desc.plan.fext_bodies[1] is 9"));
}

TEST(CpuPluginErrors, NullErrorIsNoError) {
  EXPECT_EQ(static_cast<int>(api()->error_code(nullptr)), 0);
  EXPECT_STREQ(api()->error_message(nullptr), "");
  api()->error_delete(nullptr);
}

}  // namespace
}  // namespace rbdgrad::testing
