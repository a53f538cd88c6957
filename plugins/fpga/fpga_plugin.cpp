// The FPGA backend's plugin table: the fixed-point gradient kernel (kernel/) on an FPGA card
// through XRT, or, with the option emulation=csim, its C simulation on the host CPU, which
// computes the same Q16.16 arithmetic and says so (describe_instance mode "csim"). Without a card,
// an xclbin or XRT, every instance creation says why it cannot run (RBDGRAD_ERROR_UNAVAILABLE).
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "common/batch_plan.hpp"
#include "common/batch_view.hpp"
#include "common/entry_checks.hpp"
#include "common/error.hpp"
#include "common/host_api.hpp"
#include "common/model_desc.hpp"
#include "common/options.hpp"
#include "host/csim_runner.hpp"
#include "host/fpga_instance.hpp"
#include "host/latency_model.hpp"
#include "rbdgrad/plugin_api.h"
#ifdef RBDGRAD_HAVE_XRT
#include "host/xrt_runner.hpp"
#endif

#ifndef RBDGRAD_VERSION
#define RBDGRAD_VERSION "unknown"
#endif

// Completes the ABI's opaque instance type for this plugin.
struct rbdgrad_instance {
  std::unique_ptr<rbdgrad::fpga::FpgaInstance> fpga;
  rbdgrad::Model model;  // for estimate_latency
};

namespace rbdgrad::plugin {
namespace {

// the oldest host minor this plugin works with: describe_instance and OUT_OF_RANGE are extras
constexpr std::uint32_t kMinHostMinor = 0;
constexpr std::uint32_t kPrecisions = RBDGRAD_PRECISION_FIXED_Q16_16;
// states per kernel run: enough to keep the pipeline busy, few enough that double buffering
// overlaps most of a batch's packing (docs/fpga.md)
constexpr std::uint64_t kDefaultChunkStates = 64;
constexpr std::uint64_t kMaxChunkStates = 65536;
constexpr std::uint64_t kDefaultTimeoutMs = 10000;

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  return guarded([&]() -> Status {
    if (Status s = check_info(info); !s) return s;
    info->name = "fpga";
    info->version = RBDGRAD_VERSION;
    info->precisions = kPrecisions;
    info->outputs = fpga::kFpgaOutputs;
    info->max_batch = 0;  // chunked
    info->max_nv = static_cast<std::uint32_t>(fpga::kDeviceMaxNv);
    return Status::ok();
  });
}

rbdgrad_error* can_run(const rbdgrad_model_desc* model, std::uint32_t precision, std::uint32_t outputs, std::uint64_t n) {
  return guarded([&]() -> Status {
    if (Status s = check_can_run_question(model, n); !s) return s;
    if (Status s = check_request(precision, outputs, kPrecisions, fpga::kFpgaOutputs); !s) return s;
    if (model->nv > static_cast<std::uint32_t>(fpga::kDeviceMaxNv))
      return unimplemented("model has " + std::to_string(model->nv) + " joints, more than the " +
                           std::to_string(fpga::kDeviceMaxNv) + " the FPGA kernel takes");
    return Status::ok();
  });
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* desc, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  return guarded([&]() -> Status {
    if (instance == nullptr) return invalid_argument("instance is NULL");
    *instance = nullptr;
    if (desc == nullptr) return invalid_argument("model is NULL");
    // emulation: "csim" runs the kernel's C simulation on the host; "none" (default) needs a card.
    // device: the card's index or PCIe BDF (default 0); xclbin: its bitstream.
    // chunk_states: states per kernel run (double-buffered); timeout_ms: for one run.
    if (Status s = check_options(options, {"emulation", "device", "xclbin", "chunk_states", "timeout_ms"}); !s)
      return s;
    const char* emulation = find_option(options, "emulation");
    const std::string mode = emulation != nullptr ? emulation : "none";
    if (mode != "csim" && mode != "none")
      return invalid_argument("option 'emulation' is '" + mode + "': expected 'csim' or 'none'");
    std::uint64_t chunk = kDefaultChunkStates;
    if (Status s = option_uint(options, "chunk_states", 1, kMaxChunkStates, chunk); !s) return s;
    std::uint64_t timeout_ms = kDefaultTimeoutMs;
    if (Status s = option_uint(options, "timeout_ms", 1, std::uint64_t{1} << 31, timeout_ms); !s) return s;
    Model model;
    if (Status s = model_from_desc(*desc, model); !s) return s;
    std::optional<BatchPlan> plan;
    if (Status s = plan_from_desc(*desc, fpga::kFpgaOutputs, plan); !s) return s;
    if (model.nv > fpga::kDeviceMaxNv)
      return unimplemented("model has " + std::to_string(model.nv) + " joints, more than the " +
                           std::to_string(fpga::kDeviceMaxNv) + " the FPGA kernel takes");

    std::unique_ptr<fpga::KernelRunner> runner;
    if (mode == "csim") {
      runner = std::make_unique<fpga::CsimRunner>(model.nv, static_cast<std::size_t>(chunk));
    } else {
#ifdef RBDGRAD_HAVE_XRT
      fpga::XrtRunnerOptions xrt;
      if (const char* d = find_option(options, "device")) xrt.device = d;
      if (const char* x = find_option(options, "xclbin")) xrt.xclbin = x;
      xrt.timeout = std::chrono::milliseconds(static_cast<std::int64_t>(timeout_ms));
      if (Status s = fpga::make_xrt_runner(xrt, model.nv, static_cast<std::size_t>(chunk), runner); !s) return s;
#else
      return unavailable("this build has no XRT (libxrt-dev was not found): no FPGA; set 'emulation: csim' to run "
                         "the kernel's C simulation");
#endif
    }
    auto made = std::make_unique<rbdgrad_instance>();
    if (Status s = fpga::FpgaInstance::create(model, std::move(runner), static_cast<std::size_t>(chunk), made->fpga,
                                              std::move(plan));
        !s)
      return s;
    made->model = std::move(model);
    *instance = made.release();
    return Status::ok();
  });
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->fpga) return invalid_argument("instance is NULL");
    return instance->fpga->compute(batch);
  });
}

void destroy_instance(rbdgrad_instance* instance) {
  guarded([&] { delete instance; });
}

rbdgrad_error* describe_instance(const rbdgrad_instance* instance, rbdgrad_instance_info* info) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->fpga) return invalid_argument("instance is NULL");
    if (Status st = check_instance_info(info); !st) return st;
    info->mode = instance->fpga->runner().mode();
    info->device = instance->fpga->runner().device().c_str();
    if (instance_info_has_detail(*info)) info->detail = "";
    return Status::ok();
  });
}

// The cycle model (host/latency_model.hpp) at its default clock: what the card would take, also
// while the kernel runs as a C simulation (whose own time says nothing about the card's). The
// columns are the instance's: a scene's plan with one derivative (or none) runs fewer column passes
// and is predicted so; without a plan, both (the ABI's question is the whole gradient).
rbdgrad_error* estimate_latency(const rbdgrad_instance* instance, std::uint32_t precision, std::uint32_t input_kind,
                                std::uint64_t n, double* microseconds) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->fpga) return invalid_argument("instance is NULL");
    if (microseconds == nullptr) return invalid_argument("microseconds is NULL");
    if (n == 0) return invalid_argument("n is 0");
    if (precision != RBDGRAD_PRECISION_FIXED_Q16_16)
      return unimplemented("the fpga backend computes in fixed point (Q16.16) only");
    if (input_kind != RBDGRAD_INPUT_TAU && input_kind != RBDGRAD_INPUT_QDD)
      return invalid_argument("input_kind is " + std::to_string(input_kind));
    fpga::LatencyEstimate e;
    if (Status s = fpga::estimate_latency(instance->model, fpga::KernelTiming{}, static_cast<std::size_t>(n),
                                          input_kind == RBDGRAD_INPUT_TAU ? fpga::InputKind::kTau : fpga::InputKind::kQdd,
                                          instance->fpga->columns(), e);
        !s)
      return s;
    *microseconds = e.batch_us;
    return Status::ok();
  });
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
    &describe_instance,
    &estimate_latency,
};

}  // namespace
}  // namespace rbdgrad::plugin

// The one exported symbol (exports.map hides everything else).
extern "C" __attribute__((visibility("default"))) const rbdgrad_plugin_api* rbdgrad_plugin_entry(
    std::uint32_t host_api_major, std::uint32_t host_api_minor) {
  if (!rbdgrad::plugin::host_api_compatible("fpga", host_api_major, host_api_minor, rbdgrad::plugin::kMinHostMinor)) {
    return nullptr;
  }
  return &rbdgrad::plugin::kApi;
}
