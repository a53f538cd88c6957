// Fuzzes the URDF loader: the bytes are URDF XML for load_urdf_string. A model it accepts is then
// used as the daemon uses a configured one: its summary (logs, GetModel), locked joints (a
// configuration's locked_joints) and, through the CPU backend's plugin table (the C ABI the daemon
// dlopen()s), an instance and one batch of a zero state in f64, f32 and Q16.16 with every output.
// Besides the sanitizers, the harness checks what the loader and the backend promise:
//  - a model the loader accepts passes validate_model and the backend accepts its description;
//  - the backend never answers INTERNAL (a bug, says plugin_api.h);
//  - an f64 batch that succeeds has finite outputs (a non-finite result is an error of its own).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "common/model_desc.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/urdf.hpp"

extern "C" const rbdgrad_plugin_api* rbdgrad_plugin_entry(std::uint32_t host_api_major, std::uint32_t host_api_minor);

using rbdgrad::fuzz::verbose;

namespace {

// dynamics cost grows with nv^2 to nv^3: larger models take the loader and checks only
constexpr int kMaxNvForDynamics = 64;


[[noreturn]] void fail(const char* what, const std::string& detail) {
  rbdgrad::fuzz::fail("urdf_fuzzer", what, detail);
}

using rbdgrad::fuzz::PluginError;
using rbdgrad::fuzz::take;

std::size_t scalar_bytes(std::uint32_t precision) { return precision == RBDGRAD_PRECISION_F64 ? 8 : 4; }

// One state of zeros (q, qd and tau or qdd) with every output, in `precision`.
void compute_zero_state(const rbdgrad_plugin_api& api, rbdgrad_instance* instance, int nv, std::uint32_t precision,
                        std::uint32_t input_kind) {
  const std::size_t s = scalar_bytes(precision);
  const auto n1 = static_cast<std::size_t>(nv);
  std::vector<unsigned char> in(n1 * s, 0);  // zero is 0 in all three encodings
  std::vector<std::vector<unsigned char>> out(8);
  const std::size_t sizes[8] = {n1, n1 * n1, n1 * n1, n1 * n1, n1, n1 * n1, n1 * n1, n1 * n1};
  for (int k = 0; k < 8; ++k) out[k].assign(sizes[k] * s, 0xAB);
  std::int32_t state_status = -1;

  rbdgrad_batch b{};
  b.struct_size = sizeof(rbdgrad_batch);
  b.n = 1;
  b.precision = precision;
  b.input_kind = input_kind;
  b.outputs = 255;
  b.q = in.data();
  b.qd = in.data();
  b.u = in.data();
  b.qdd = out[0].data();
  b.minv_out = out[1].data();
  b.dqdd_dq = out[2].data();
  b.dqdd_dqd = out[3].data();
  b.tau = out[4].data();
  b.dtau_dq = out[5].data();
  b.dtau_dqd = out[6].data();
  b.m = out[7].data();
  b.state_status = &state_status;
  const PluginError e = take(api, api.compute(instance, &b));
  if (verbose())
    std::fprintf(stderr, "urdf_fuzzer: compute (precision %u): %s\n", precision, e.code == RBDGRAD_OK ? "ok" : e.message.c_str());
  if (e.code == RBDGRAD_ERROR_INTERNAL) fail("the CPU backend failed INTERNAL on a zero state", e.message);
  if (e.code == RBDGRAD_OK && state_status != RBDGRAD_OK)
    fail("compute succeeded but the state's status says it failed", std::to_string(state_status));
  if (e.code != RBDGRAD_OK || precision != RBDGRAD_PRECISION_F64) return;
  for (int k = 0; k < 8; ++k) {
    for (std::size_t i = 0; i < sizes[k]; ++i) {
      double v;
      __builtin_memcpy(&v, out[k].data() + i * 8, 8);
      if (!std::isfinite(v)) fail("an f64 batch succeeded with a non-finite output", "output " + std::to_string(k));
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  rbdgrad::Model model;
  const rbdgrad::Status loaded = rbdgrad::load_urdf_string(xml, "fuzz.urdf", model);
  if (verbose()) std::fprintf(stderr, "urdf_fuzzer: load_urdf_string: %s\n", loaded.to_string().c_str());
  if (!loaded) {
    if (loaded.message().empty()) fail("load_urdf_string failed without a message", "");
    return 0;
  }
  (void)rbdgrad::model_summary(model);
  if (std::string problem = rbdgrad::validate_model(model); !problem.empty())
    fail("load_urdf_string accepted a model that validate_model refuses", problem);

  // a locked joint, as a configuration's locked_joints: the first joint at a value within its limits
  if (model.nv >= 2) {
    const rbdgrad::JointInfo& j = model.joints[0];
    const double value = (j.lower_limit <= 0 && 0 <= j.upper_limit) ? 0.0 : 0.5 * (j.lower_limit + j.upper_limit);
    rbdgrad::Model reduced;
    if (rbdgrad::Status s = rbdgrad::lock_joints(model, {{j.name, value}}, reduced); s) {
      if (std::string problem = rbdgrad::validate_model(reduced); !problem.empty())
        fail("lock_joints made a model that validate_model refuses", problem);
    }
  }

  if (model.nv > kMaxNvForDynamics) return 0;
  static const rbdgrad_plugin_api* const api = rbdgrad_plugin_entry(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  if (api == nullptr) fail("the CPU plugin refused this host's API version", "");
  const rbdgrad::plugin::ModelDesc desc(model);
  const char* keys[] = {"threads"};
  const char* values[] = {"1"};  // the calling thread only: no pool threads per input
  const rbdgrad_options options{sizeof(rbdgrad_options), 1, keys, values};
  rbdgrad_instance* instance = nullptr;
  if (PluginError e = take(*api, api->create_instance(&desc.desc(), &options, &instance)); e.code != RBDGRAD_OK)
    fail("the CPU backend refused a model the URDF loader accepted", e.message);
  compute_zero_state(*api, instance, model.nv, RBDGRAD_PRECISION_F64, RBDGRAD_INPUT_TAU);
  compute_zero_state(*api, instance, model.nv, RBDGRAD_PRECISION_F32, RBDGRAD_INPUT_QDD);
  compute_zero_state(*api, instance, model.nv, RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU);
  api->destroy_instance(instance);
  return 0;
}
