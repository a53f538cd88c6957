// The result file header of `rbdgrad eval` and `rbdgrad compute`.
#include "result_header.hpp"

namespace rbdgrad::cli {

nlohmann::ordered_json result_header_json(const ResultHeader& h) {
  nlohmann::ordered_json j;  // keys in the order written, like the reference headers
  j["robot"] = h.robot;
  j["source"] = h.source;
  j["nq"] = h.nv;
  j["nv"] = h.nv;
  j["joint_names"] = h.joint_names;
  j["gravity"] = h.gravity;
  j["precision"] = h.precision;
  j["outputs"] = h.outputs;
  j["input"] = h.input;
  j["n_states"] = h.n_states;
  j["generator"] = h.generator;
  j["convention"] =
      "Joint order = joint_names (Pinocchio's depth-first order). Matrices are nv x nv, row-major: element (i,j) "
      "at index i*nv+j; d(a)/d(b) has row i = a_i, column j = b_j. qdd = FD(q,qd,tau) when the state has tau, "
      "else the input qdd; tau_id = RNEA(q,qd,qdd) and dtau_dq, dtau_dqd are evaluated at that qdd. Computed in "
      "the given precision, written as float64 with 17 significant digits.";
  return j;
}

std::string dump_header(const nlohmann::ordered_json& header) {
  return header.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace rbdgrad::cli
