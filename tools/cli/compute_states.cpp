// Random and file states for `rbdgrad compute`.
#include "compute_states.hpp"

#include <numbers>
#include <random>

namespace rbdgrad::cli {

std::vector<InputState> random_states(const ModelDescription& model, std::uint32_t n, std::uint64_t seed,
                                      ComputeInput input) {
  std::mt19937_64 rng(seed);
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  std::vector<InputState> states(n);
  for (std::uint32_t k = 0; k < n; ++k) {
    InputState& s = states[k];
    s.index = static_cast<long>(k);
    s.kind = "random";
    s.input = input;
    for (const JointDescription& j : model.joints) {
      double lo = -std::numbers::pi, hi = std::numbers::pi;
      if (j.has_position_limits()) lo = j.lower_limit, hi = j.upper_limit;
      else if (j.type == "prismatic") lo = -0.5, hi = 0.5;
      s.q.push_back(uniform(lo, hi));
      s.qd.push_back(uniform(-1.0, 1.0));
      const double effort = j.effort_limit > 0 ? 0.5 * j.effort_limit : 10.0;
      s.u.push_back(input == ComputeInput::kTau ? uniform(-effort, effort) : uniform(-5.0, 5.0));
    }
  }
  return states;
}

std::vector<InputState> file_states(const io::StateFile& file, int nv, const ComputeInput* forced) {
  std::vector<InputState> states;
  states.reserve(file.states.size());
  for (const io::StateRecord& record : file.states) {
    InputState& s = states.emplace_back();
    s.index = record.index;
    s.kind = record.kind;
    s.input = forced ? *forced : record.has("tau") ? ComputeInput::kTau : ComputeInput::kQdd;
    // eval's checks (sizes, finite values) on q, qd and the field that is the input
    if (!forced) s.error = io::check_dynamics_input(record, nv);
    for (const char* field : {"q", "qd", input_name(s.input)})
      if (forced && s.error.empty()) s.error = io::check_field(record, field, nv);
    if (!s.error.empty()) continue;
    s.q = *record.find("q");
    s.qd = *record.find("qd");
    s.u = *record.find(input_name(s.input));
  }
  return states;
}

}  // namespace rbdgrad::cli
