// Writes the seed inputs of request_fuzzer: serialized rbdgrad.v1.ComputeRequests for the
// harness's daemon (the embedded iiwa14, nv 7, and its scenes "arm", nv 6 with force links
// iiwa_link_6 and iiwa_link_3, and "arm_minv", which takes M^-1). Generated at build time so
// that no binary is committed and the seeds follow the proto.
//   make_request_seeds DIR
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "rbdgrad/v1/dynamics.pb.h"

namespace {

namespace v1 = rbdgrad::v1;

void set_tensor(v1::Tensor* t, v1::ScalarType type, const std::vector<double>& values) {
  t->set_type(type);
  std::string bytes;
  for (double v : values) {
    if (type == v1::SCALAR_TYPE_F32) {
      const auto f = static_cast<float>(v);
      bytes.append(reinterpret_cast<const char*>(&f), sizeof f);  // little-endian hosts only, as the server
    } else {
      bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
  }
  t->set_data(bytes);
}

std::vector<double> ramp(std::size_t count, double scale) {
  std::vector<double> v(count);
  for (std::size_t i = 0; i < count; ++i) v[i] = scale * static_cast<double>(i % 7 + 1);
  return v;
}

std::vector<double> identity(std::size_t n, std::size_t nv) {
  std::vector<double> v(n * nv * nv, 0.0);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t i = 0; i < nv; ++i) v[k * nv * nv + i * nv + i] = 1.0;
  return v;
}

// A request of `n` states of a model with `nv` joints, inputs of `type`.
v1::ComputeRequest request(const std::string& model, std::size_t n, std::size_t nv, v1::ScalarType type) {
  v1::ComputeRequest r;
  r.set_model(model);
  r.set_num_states(static_cast<unsigned>(n));
  r.set_input_kind(v1::INPUT_KIND_TAU);
  set_tensor(r.mutable_q(), type, ramp(n * nv, 0.1));
  set_tensor(r.mutable_qd(), type, ramp(n * nv, -0.2));
  set_tensor(r.mutable_u(), type, ramp(n * nv, 1.5));
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_request_seeds DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  std::vector<std::pair<std::string, v1::ComputeRequest>> seeds;

  {  // the usual MPC call: f64, the forward-dynamics gradient
    v1::ComputeRequest r = request("iiwa14", 1, 7, v1::SCALAR_TYPE_F64);
    r.set_precision(v1::PRECISION_F64);
    for (auto o : {v1::OUTPUT_QDD, v1::OUTPUT_DQDD_DQ, v1::OUTPUT_DQDD_DQD}) r.add_outputs(o);
    seeds.emplace_back("gradient_f64", r);
  }
  {  // f32 in and out, qdd input, every output, an id and a backend hint
    v1::ComputeRequest r = request("iiwa14", 2, 7, v1::SCALAR_TYPE_F32);
    r.set_precision(v1::PRECISION_F32);
    r.set_input_kind(v1::INPUT_KIND_QDD);
    r.set_output_type(v1::SCALAR_TYPE_F32);
    r.set_backend(v1::BACKEND_CPU);
    r.set_request_id("seed-f32");
    for (int o = v1::OUTPUT_QDD; o <= v1::OUTPUT_M; ++o) r.add_outputs(static_cast<v1::Output>(o));
    seeds.emplace_back("all_outputs_f32", r);
  }
  {  // fixed point with a supplied M^-1 and external forces
    v1::ComputeRequest r = request("iiwa14", 1, 7, v1::SCALAR_TYPE_F64);
    r.set_precision(v1::PRECISION_FIXED);
    set_tensor(r.mutable_minv(), v1::SCALAR_TYPE_F64, identity(1, 7));
    set_tensor(r.mutable_fext(), v1::SCALAR_TYPE_F64, ramp(7 * 6, 0.5));
    for (auto o : {v1::OUTPUT_DQDD_DQ, v1::OUTPUT_TAU, v1::OUTPUT_M}) r.add_outputs(o);
    seeds.emplace_back("fixed_minv_fext", r);
  }
  {  // the scene "arm": its outputs by default, forces on its two force links
    v1::ComputeRequest r = request("", 2, 6, v1::SCALAR_TYPE_F64);
    r.set_scene("arm");
    set_tensor(r.mutable_fext(), v1::SCALAR_TYPE_F64, ramp(2 * 2 * 6, 1.0));
    seeds.emplace_back("scene_arm_fext", r);
  }
  {  // the scene "arm_minv": M^-1 with every request, a subset of its outputs, its model named
    v1::ComputeRequest r = request("iiwa14", 1, 7, v1::SCALAR_TYPE_F32);
    r.set_scene("arm_minv");
    set_tensor(r.mutable_minv(), v1::SCALAR_TYPE_F32, identity(1, 7));
    r.add_outputs(v1::OUTPUT_DQDD_DQ);
    seeds.emplace_back("scene_arm_minv", r);
  }
  {  // refused: three states announced, one given
    v1::ComputeRequest r = request("iiwa14", 1, 7, v1::SCALAR_TYPE_F64);
    r.set_num_states(3);
    r.add_outputs(v1::OUTPUT_QDD);
    seeds.emplace_back("wrong_count", r);
  }
  {  // refused: a value outside Q16.16
    v1::ComputeRequest r = request("iiwa14", 1, 7, v1::SCALAR_TYPE_F64);
    r.set_precision(v1::PRECISION_FIXED);
    set_tensor(r.mutable_u(), v1::SCALAR_TYPE_F64, ramp(7, 40000.0));
    r.add_outputs(v1::OUTPUT_QDD);
    seeds.emplace_back("fixed_out_of_range", r);
  }

  for (const auto& [name, r] : seeds) {
    std::ofstream out(dir + "/" + name + ".pb", std::ios::binary);
    if (!r.SerializeToOstream(&out) || !out.flush()) {
      std::fprintf(stderr, "make_request_seeds: cannot write %s/%s.pb\n", dir.c_str(), name.c_str());
      return 1;
    }
  }
  std::printf("make_request_seeds: %zu requests in %s\n", seeds.size(), dir.c_str());
  return 0;
}
