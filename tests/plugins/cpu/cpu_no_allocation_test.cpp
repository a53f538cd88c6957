// Tests that compute of plugins/cpu allocates nothing once the instance exists (STYLE.md point 5),
// on the caller's thread and on the pool threads. Own executable: it replaces the global operator
// new, which the dlopen()ed plugin also calls (it links libstdc++ dynamically).
#include <gtest/gtest.h>

#include "../../support/counting_new.hpp"

#include <random>

#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "common/model_desc.hpp"

namespace rbdgrad::testing {
namespace {

template <class Raw>
void expect_no_allocation(const rbdgrad_plugin_api* api, rbdgrad_instance* instance, int nv, std::uint32_t precision) {
  BatchArrays<Raw> a(50, nv);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  auto value = [&] {
    if constexpr (std::is_same_v<Raw, std::int32_t>) return static_cast<Raw>(u(rng) * 65536);
    else return static_cast<Raw>(u(rng));
  };
  for (std::vector<Raw>* v : {&a.q, &a.qd, &a.u, &a.fext}) for (Raw& x : *v) x = value();
  // a plausible M^-1: the identity
  for (std::size_t k = 0; k < a.n; ++k)
    for (std::size_t i = 0; i < a.nv; ++i)
      a.minv[(k * a.nv + i) * a.nv + i] = std::is_same_v<Raw, std::int32_t> ? Raw(65536) : Raw(1);
  for (const std::uint32_t kind : {RBDGRAD_INPUT_TAU, RBDGRAD_INPUT_QDD})
    for (const std::uint32_t outputs : {255u, 1u, 16u | 128u, 128u, 2u | 4u})
      for (const bool extras : {false, true}) {
        const rbdgrad_batch b = a.batch(precision, kind, outputs, extras, extras);
        rbdgrad_error* warm = api->compute(instance, &b);  // first use of this precision's buffers
        const long before = g_allocations.load();
        rbdgrad_error* e = api->compute(instance, &b);
        const long allocations = g_allocations.load() - before;
        EXPECT_EQ(allocations, 0) << "precision " << precision << " outputs " << outputs << " input " << kind
                                  << (extras ? " with M^-1 and fext" : "");
        EXPECT_EQ(e, nullptr) << (e ? api->error_message(e) : "");
        api->error_delete(warm);
        api->error_delete(e);
      }
}

TEST(CpuPluginNoAllocation, ComputeNeverAllocates) {
  const rbdgrad_plugin_api* api =
      load_plugin_entry(RBDGRAD_CPU_PLUGIN_PATH)(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  ASSERT_NE(api, nullptr);
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    const plugin::ModelDesc desc(load_embedded(robot));
    for (const char* threads : {"1", "4"}) {
      const long at_start = g_allocations.load();
      InstancePtr instance = create(api, desc.desc(), {{"threads", threads}});
      ASSERT_NE(instance, nullptr);
      ASSERT_GT(g_allocations.load(), at_start) << "the allocation counter does not see the plugin";
      const int nv = static_cast<int>(desc.desc().nv);
      expect_no_allocation<double>(api, instance.get(), nv, RBDGRAD_PRECISION_F64);
      expect_no_allocation<float>(api, instance.get(), nv, RBDGRAD_PRECISION_F32);
      expect_no_allocation<std::int32_t>(api, instance.get(), nv, RBDGRAD_PRECISION_FIXED_Q16_16);
    }
  }
}

}  // namespace
}  // namespace rbdgrad::testing
