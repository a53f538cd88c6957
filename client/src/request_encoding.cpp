// ComputeRequest -> rbdgrad.v1.ComputeRequest, and the enum and status conversions at the edge.
#include "request_encoding.hpp"

#include <bit>
#include <string>

namespace rbdgrad::detail {

// Tensors carry little-endian IEEE-754 values: on a little-endian host the bytes are the doubles.
static_assert(std::endian::native == std::endian::little, "rbdgrad's wire format needs a little-endian host");

namespace {

// One array into a tensor; an empty span clears the field (optional inputs: minv, fext).
void set_tensor(std::span<const double> values, v1::Tensor* tensor) {
  tensor->set_type(v1::SCALAR_TYPE_F64);
  // assigning into the existing string keeps its capacity: a reused message does not allocate
  tensor->mutable_data()->assign(reinterpret_cast<const char*>(values.data()), values.size_bytes());
}

}  // namespace

ExpectedResult expected_result(const ComputeRequest& req) noexcept {
  ExpectedResult e;
  e.num_states = req.num_states;
  e.outputs = req.outputs;
  e.type = req.output_type;
  if (req.num_states > 0 && req.q.size() % req.num_states == 0) e.nv = static_cast<int>(req.q.size() / req.num_states);
  return e;
}

namespace {

constexpr std::uint32_t kKnownBits = 255;

RpcStatus unknown_output_bits(std::uint32_t outputs) {
  if (const std::uint32_t unknown = outputs & ~kKnownBits; unknown != 0)
    return {RpcCode::kInvalidArgument, "client: outputs has bits that name no output (" + std::to_string(unknown) +
                                           "; the outputs are the bits 1 to 128)"};
  return RpcStatus::ok();
}

}  // namespace

RpcStatus encode_scene_definition(const SceneDefinition& scene, v1::RegisterSceneRequest& msg) {
  if (RpcStatus st = unknown_output_bits(scene.outputs); !st) return st;
  msg.Clear();
  msg.set_name(scene.name);
  msg.set_model(scene.model);
  for (const auto& [joint, value] : scene.locked_joints) {
    msg.add_locked_joints(joint);
    msg.add_locked_values(value);
  }
  msg.set_gravity(scene.gravity);
  for (const std::string& link : scene.force_links) msg.add_force_links(link);
  // none: the server's default (dqdd_dq, dqdd_dqd)
  for (Output o : kEveryOutput)
    if (scene.outputs & mask(o)) msg.add_outputs(output_to_proto(o));
  msg.set_minv_supplied(scene.minv_supplied);
  return RpcStatus::ok();
}

RpcStatus encode_request(const ComputeRequest& req, v1::ComputeRequest& msg) {
  if (RpcStatus st = unknown_output_bits(req.outputs); !st) return st;
  msg.set_model(req.model);
  msg.set_scene(req.scene);
  msg.set_num_states(req.num_states);
  msg.set_precision(to_proto(req.precision));
  msg.set_input_kind(req.input == ComputeInput::kQdd ? v1::INPUT_KIND_QDD : v1::INPUT_KIND_TAU);
  msg.clear_outputs();
  for (Output o : kEveryOutput)
    if (req.outputs & mask(o)) msg.add_outputs(output_to_proto(o));
  set_tensor(req.q, msg.mutable_q());
  set_tensor(req.qd, msg.mutable_qd());
  set_tensor(req.u, msg.mutable_u());
  if (req.minv.empty()) msg.clear_minv();
  else set_tensor(req.minv, msg.mutable_minv());
  if (req.fext.empty()) msg.clear_fext();
  else set_tensor(req.fext, msg.mutable_fext());
  msg.set_backend(to_proto(req.backend));
  msg.set_output_type(req.output_type == ScalarType::kF32 ? v1::SCALAR_TYPE_F32 : v1::SCALAR_TYPE_F64);
  msg.set_request_id(req.request_id);
  return RpcStatus::ok();
}

RpcStatus from_grpc(const grpc::Status& status) {
  return {static_cast<RpcCode>(status.error_code()), status.error_message()};
}

v1::Precision to_proto(Precision p) noexcept {
  switch (p) {
    case Precision::kAuto: return v1::PRECISION_AUTO;
    case Precision::kF64: return v1::PRECISION_F64;
    case Precision::kF32: return v1::PRECISION_F32;
    case Precision::kFixed: return v1::PRECISION_FIXED;
  }
  return v1::PRECISION_AUTO;
}

v1::Backend to_proto(Backend b) noexcept {
  switch (b) {
    case Backend::kAuto: return v1::BACKEND_AUTO;
    case Backend::kCpu: return v1::BACKEND_CPU;
    case Backend::kCuda: return v1::BACKEND_CUDA;
    case Backend::kFpga: return v1::BACKEND_FPGA;
  }
  return v1::BACKEND_AUTO;
}

Precision from_proto(v1::Precision p) noexcept {
  switch (p) {
    case v1::PRECISION_F64: return Precision::kF64;
    case v1::PRECISION_F32: return Precision::kF32;
    case v1::PRECISION_FIXED: return Precision::kFixed;
    default: return Precision::kAuto;
  }
}

Backend from_proto(v1::Backend b) noexcept {
  switch (b) {
    case v1::BACKEND_CPU: return Backend::kCpu;
    case v1::BACKEND_CUDA: return Backend::kCuda;
    case v1::BACKEND_FPGA: return Backend::kFpga;
    default: return Backend::kAuto;
  }
}

v1::Output output_to_proto(Output o) noexcept {
  switch (o) {
    case Output::kQdd: return v1::OUTPUT_QDD;
    case Output::kMinv: return v1::OUTPUT_MINV;
    case Output::kDqddDq: return v1::OUTPUT_DQDD_DQ;
    case Output::kDqddDqd: return v1::OUTPUT_DQDD_DQD;
    case Output::kTau: return v1::OUTPUT_TAU;
    case Output::kDtauDq: return v1::OUTPUT_DTAU_DQ;
    case Output::kDtauDqd: return v1::OUTPUT_DTAU_DQD;
    case Output::kM: return v1::OUTPUT_M;
  }
  return v1::OUTPUT_UNSPECIFIED;
}

}  // namespace rbdgrad::detail
