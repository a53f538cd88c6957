// Fuzzes the decoding and validation of a Compute request: the bytes are the message body of a
// Compute (or one ComputeStream message), a serialized rbdgrad.v1.ComputeRequest.
//
// It runs the steps of ComputeCall::prepare (server/compute_call.cpp) that need no gRPC server,
// scheduler or loaded plugin, in the same order and with the daemon's functions: the parse from a
// grpc::ByteBuffer (ProtoBufferReader), the model or scene lookup in a ModelRegistry, apply_scene,
// the backend and precision enums, RequestBatch::from_request (with the response as its direct
// output, as prepare passes it) and the backend's can_run; then what runs after prepare for an
// accepted request: the CPU backend's compute through its plugin table, RequestBatch::to_response
// and the response's serialization. Errors become gRPC statuses as the handlers do.
// The daemon's set-up is the default configuration's (the embedded iiwa14, max_states_per_request
// 65536) and two scenes of it (SceneConfig below), with the CPU backend only.
// Not covered (they need the running server or its routing): Scheduler::route and split, the
// deadline check, dynamic batching, failover and the fixed-point fallback (prepare_fallback), the
// gRPC reactors of Compute and ComputeStream. See docs/fuzzing.md.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/slice.h>

#include "fuzz_support.hpp"
#include "grpc_status.hpp"
#include "model_registry.hpp"
#include "proto_enums.hpp"
#include "rbdgrad/plugin_api.h"
#include "request_batch.hpp"
#include "scene.hpp"

extern "C" const rbdgrad_plugin_api* rbdgrad_plugin_entry(std::uint32_t host_api_major, std::uint32_t host_api_minor);

using rbdgrad::fuzz::verbose;

namespace {

namespace server = rbdgrad::server;
namespace v1 = rbdgrad::v1;
using rbdgrad::Status;


[[noreturn]] void fail(const char* what, const std::string& detail) {
  rbdgrad::fuzz::fail("request_fuzzer", what, detail);
}

using rbdgrad::fuzz::PluginError;
using rbdgrad::fuzz::take;

// What the daemon holds after start-up: the models and scenes, and one CPU instance of each.
struct Daemon {
  server::ModelRegistry models;
  const rbdgrad_plugin_api* cpu = nullptr;
  std::vector<rbdgrad_instance*> instances;  // by ServedModel::index
  server::LimitsConfig limits;               // the defaults
};

const Daemon& daemon_state() {
  static const Daemon* const daemon = [] {
    auto d = std::make_unique<Daemon>();
    const std::vector<server::ModelConfig> models = {{"iiwa14", "", "iiwa14", std::nullopt, {}}};
    // a scene with locked joints, no gravity, force links and a few outputs; one that takes M^-1
    server::SceneConfig arm;
    arm.name = "arm";
    arm.model = "iiwa14";
    arm.locked_joints = {{"iiwa_joint_7", 0.0}};
    arm.gravity = false;
    arm.force_links = {"iiwa_link_6", "iiwa_link_3"};
    arm.outputs = {"qdd", "dqdd_dq", "dqdd_dqd", "tau"};
    server::SceneConfig arm_minv;
    arm_minv.name = "arm_minv";
    arm_minv.model = "iiwa14";
    arm_minv.minv = "supplied";
    if (Status s = server::ModelRegistry::load(models, {arm, arm_minv}, d->models); !s)
      fail("cannot load the models", s.to_string());
    d->cpu = rbdgrad_plugin_entry(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
    if (d->cpu == nullptr) fail("the CPU plugin refused this host's API version", "");
    const char* keys[] = {"threads"};
    const char* values[] = {"1"};  // the calling thread only
    const rbdgrad_options options{sizeof(rbdgrad_options), 1, keys, values};
    for (const auto& m : d->models.models()) {
      rbdgrad_instance* instance = nullptr;
      if (PluginError e = take(*d->cpu, d->cpu->create_instance(&m->desc.desc(), &options, &instance));
          e.code != RBDGRAD_OK)
        fail("the CPU backend refused a model", m->name + ": " + e.message);
      d->instances.push_back(instance);
    }
    return d.release();  // lives for the process, as the daemon's
  }();
  return *daemon;
}

// BackendPool::route with the CPU backend alone: a hint for another backend is unavailable, and
// "auto" precision is the CPU's best, f64.
Status route(std::string_view backend, std::uint32_t precision, rbdgrad_precision& out) {
  if (!backend.empty() && backend != "cpu")
    return rbdgrad::unavailable("backend " + std::string(backend) + " is not available: not configured");
  out = precision == 0 ? RBDGRAD_PRECISION_F64 : static_cast<rbdgrad_precision>(precision);
  return Status::ok();
}

std::size_t scalar_bytes(v1::ScalarType type) { return type == v1::SCALAR_TYPE_F32 ? 4 : 8; }

// The steps of prepare() and of an accepted request's run; the Status is what the client gets.
Status handle(const Daemon& d, const grpc::ByteBuffer& message) {
  v1::ComputeRequest request;
  {
    grpc::ByteBuffer view(message);
    grpc::ProtoBufferReader reader(&view);
    if (!reader.status().ok() || !request.ParseFromZeroCopyStream(&reader))
      return rbdgrad::invalid_argument("malformed ComputeRequest");
  }
  const server::ServedModel* model = nullptr;
  if (!request.scene().empty()) {
    model = d.models.find_scene(request.scene());
    if (model == nullptr) return rbdgrad::not_found("scene '" + request.scene() + "' is not configured");
    if (Status s = server::apply_scene(*model->scene, model->name, model->model.nv, request); !s) return s;
  } else {
    model = d.models.find(request.model());
    if (model == nullptr) return rbdgrad::not_found("model '" + request.model() + "' is not loaded");
  }
  std::string_view backend;
  if (!server::backend_name(request.backend(), backend)) return rbdgrad::invalid_argument("backend has unknown value");
  std::uint32_t asked = 0;
  if (!server::precision_flag(request.precision(), asked)) return rbdgrad::invalid_argument("precision has unknown value");
  rbdgrad_precision precision = RBDGRAD_PRECISION_F64;
  if (Status s = route(backend, asked, precision); !s) return s;

  v1::ComputeResponse response;
  server::RequestBatch batch;
  const auto max_states = static_cast<std::uint32_t>(d.limits.max_states_per_request);
  if (Status s = server::RequestBatch::from_request(request, model->model.nv, precision, max_states, batch, &response);
      !s)
    return s;
  const rbdgrad_batch& b = batch.batch();
  if (b.n != request.num_states() || b.precision != static_cast<std::uint32_t>(precision))
    fail("from_request made a batch of another size or precision", request.ShortDebugString());
  if (PluginError e = take(*d.cpu, d.cpu->can_run(&model->desc.desc(), precision, b.outputs, b.n)); e.code != RBDGRAD_OK)
    return Status(rbdgrad::StatusCode::kUnimplemented, e.message);

  // the accepted request runs
  const PluginError e = take(*d.cpu, d.cpu->compute(d.instances.at(model->index), &b));
  if (e.code == RBDGRAD_ERROR_INTERNAL) fail("the CPU backend failed INTERNAL on a validated batch", e.message);
  if (e.code == RBDGRAD_ERROR_INVALID_ARGUMENT)
    fail("the CPU backend refused a batch that RequestBatch and can_run accepted", e.message);
  if (e.code != RBDGRAD_OK) return Status(rbdgrad::StatusCode::kFailedPrecondition, e.message);
  batch.to_response(response, request.output_type());
  // every requested output is there, N x nv (x nv) in the wire type
  const std::size_t nv = static_cast<std::size_t>(model->model.nv);
  for (int o : request.outputs()) {
    const auto output = static_cast<v1::Output>(o);
    const std::size_t per_state = server::is_matrix_output(output) ? nv * nv : nv;
    const v1::Tensor* t = server::response_tensor(response, output);
    if (t == nullptr || t->data().size() != b.n * per_state * scalar_bytes(request.output_type()))
      fail("the response's output has the wrong size", v1::Output_Name(output));
  }
  std::string bytes;
  if (!response.SerializeToString(&bytes)) fail("cannot serialize the response", "");
  return Status::ok();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Daemon& d = daemon_state();
  grpc::Slice slice(data, size);
  const grpc::ByteBuffer message(&slice, 1);
  const Status s = handle(d, message);
  if (verbose()) std::fprintf(stderr, "request_fuzzer: %s\n", s.is_ok() ? "computed" : s.to_string().c_str());
  if (!s && s.message().empty()) fail("an error without a message", rbdgrad::status_code_name(s.code()));
  (void)server::to_grpc_status(s);
  return 0;
}
