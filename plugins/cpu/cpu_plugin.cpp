// The CPU backend's plugin table: the core library on a pool of worker threads, in f64, f32 and
// Q16.16 fixed point (a bit-exact software model of the FPGA kernels' arithmetic).
#include <chrono>
#include <memory>
#include <optional>
#include <thread>

#include "common/batch_plan.hpp"
#include "common/batch_view.hpp"
#include "common/entry_checks.hpp"
#include "common/error.hpp"
#include "common/host_api.hpp"
#include "common/model_desc.hpp"
#include "common/options.hpp"
#include "cpu_instance.hpp"
#include "rbdgrad/plugin_api.h"

#ifndef RBDGRAD_VERSION
#define RBDGRAD_VERSION "unknown"
#endif

// Completes the ABI's opaque instance type for this plugin.
struct rbdgrad_instance {
  std::unique_ptr<rbdgrad::plugin::CpuInstance> cpu;
};

namespace rbdgrad::plugin {
namespace {

// the oldest host minor this plugin works with: it uses nothing added after 1.0
constexpr std::uint32_t kMinHostMinor = 0;
// more threads than this is a typo, not a machine
constexpr std::uint64_t kMaxThreads = 1024;
// a second of polling is no longer a bridge between batches
constexpr std::uint64_t kMaxIdlePollUs = 1'000'000;

std::uint64_t default_threads() {
  const unsigned hw = std::thread::hardware_concurrency();  // 0 when unknown
  return hw > 0 ? hw : 1;
}

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  return guarded([&]() -> Status {
    if (Status s = check_info(info); !s) return s;
    info->name = "cpu";
    info->version = RBDGRAD_VERSION;
    info->precisions = kAllPrecisions;
    info->outputs = kAllOutputs;
    info->max_batch = 0;
    info->max_nv = 0;
    return Status::ok();
  });
}

// Any valid model runs on the CPU: only the request itself is looked at (cheap: called per batch).
rbdgrad_error* can_run(const rbdgrad_model_desc* model, std::uint32_t precision, std::uint32_t outputs, std::uint64_t n) {
  return guarded([&]() -> Status {
    if (Status s = check_can_run_question(model, n); !s) return s;
    return check_request(precision, outputs, kAllPrecisions, kAllOutputs);
  });
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* desc, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  return guarded([&]() -> Status {
    if (instance == nullptr) return invalid_argument("instance is NULL");
    *instance = nullptr;
    if (desc == nullptr) return invalid_argument("model is NULL");
    // threads: workers, the calling thread included; idle_poll_us: see ThreadPool
    if (Status s = check_options(options, {"threads", "idle_poll_us"}); !s) return s;
    std::uint64_t threads = default_threads();
    if (Status s = option_uint(options, "threads", 1, kMaxThreads, threads); !s) return s;
    auto idle_poll_us = static_cast<std::uint64_t>(ThreadPool::kDefaultIdlePoll.count());
    if (Status s = option_uint(options, "idle_poll_us", 0, kMaxIdlePollUs, idle_poll_us); !s) return s;
    Model model;
    if (Status s = model_from_desc(*desc, model); !s) return s;
    std::optional<BatchPlan> plan;
    if (Status s = plan_from_desc(*desc, kAllOutputs, plan); !s) return s;
    auto made = std::make_unique<rbdgrad_instance>();
    if (Status s = CpuInstance::create(model, threads, made->cpu,
                                       std::chrono::microseconds(static_cast<std::int64_t>(idle_poll_us)),
                                       std::move(plan));
        !s)
      return s;
    *instance = made.release();
    return Status::ok();
  });
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->cpu) return invalid_argument("instance is NULL");
    return instance->cpu->compute(batch);
  });
}

void destroy_instance(rbdgrad_instance* instance) {
  guarded([&] { delete instance; });
}

constexpr rbdgrad_plugin_api kApi = {
    sizeof(rbdgrad_plugin_api),
    RBDGRAD_PLUGIN_API_MAJOR,
    RBDGRAD_PLUGIN_API_MINOR,
    &get_info,
    &can_run,
    &create_instance,
    &compute,
    &destroy_instance,
    &error_code,
    &error_message,
    &error_delete,
    nullptr,  // describe_instance: nothing beyond the plugin's name to say
    nullptr,  // estimate_latency: the host times the CPU (calibration)
};

}  // namespace
}  // namespace rbdgrad::plugin

// The one exported symbol (exports.map hides everything else).
extern "C" __attribute__((visibility("default"))) const rbdgrad_plugin_api* rbdgrad_plugin_entry(
    std::uint32_t host_api_major, std::uint32_t host_api_minor) {
  if (!rbdgrad::plugin::host_api_compatible("cpu", host_api_major, host_api_minor, rbdgrad::plugin::kMinHostMinor)) {
    return nullptr;
  }
  return &rbdgrad::plugin::kApi;
}
