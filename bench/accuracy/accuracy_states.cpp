#include "accuracy_states.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::bench {

StateSet random_states(const Model& model, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  StateSet s;
  s.nv = model.nv;
  s.n = n;
  const auto nv = static_cast<std::size_t>(model.nv);
  s.q.resize(n * nv);
  s.qd.resize(n * nv);
  s.tau.resize(n * nv);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t i = 0; i < nv; ++i) {
      const JointInfo& j = model.joints[i];
      double lo = -std::numbers::pi, hi = std::numbers::pi;
      if (j.lower_limit < j.upper_limit) {
        lo = j.lower_limit;
        hi = j.upper_limit;
      } else if (model.type[i] == JointType::kPrismatic) {
        lo = -0.5;
        hi = 0.5;
      }
      const double effort = j.effort_limit > 0 ? 0.5 * j.effort_limit : 10.0;
      s.q[k * nv + i] = lo + (hi - lo) * unit(rng);
      s.qd[k * nv + i] = -1.0 + 2.0 * unit(rng);
      s.tau[k * nv + i] = effort * (2.0 * unit(rng) - 1.0);
    }
  return s;
}

Status reference_states(const std::string& path, const Model& model, StateSet& out) {
  io::StateFile file;
  std::string error;
  if (!io::read_state_file(path, file, error)) return Status(StatusCode::kNotFound, error);
  out = StateSet{};
  out.nv = model.nv;
  const auto nv = static_cast<std::size_t>(model.nv);
  for (const io::StateRecord& r : file.states) {
    const char* fields[] = {"q", "qd", "tau", "dqdd_dq", "dqdd_dqd"};
    std::vector<double>* into[] = {&out.q, &out.qd, &out.tau, &out.dqdd_dq, &out.dqdd_dqd};
    for (int f = 0; f < 5; ++f) {
      const std::vector<double>* v = r.find(fields[f]);
      const std::size_t want = f < 3 ? nv : nv * nv;
      if (v == nullptr || v->size() != want)
        return invalid_argument(path + ": state " + std::to_string(r.index) + ": field '" + fields[f] + "' " +
                                (v == nullptr ? "is missing" : "has " + std::to_string(v->size()) + " values") +
                                ", expected " + std::to_string(want));
      into[f]->insert(into[f]->end(), v->begin(), v->end());
    }
    ++out.n;
  }
  if (out.n == 0) return invalid_argument(path + ": no states");
  return Status::ok();
}

StateSet first_states(const StateSet& set, std::size_t n) {
  StateSet s;
  s.nv = set.nv;
  s.n = n;
  const auto nv = static_cast<std::size_t>(set.nv);
  const auto take = [&](const std::vector<double>& from, std::size_t per_state, std::vector<double>& to) {
    if (from.empty()) return;
    to.resize(n * per_state);
    for (std::size_t k = 0; k < n; ++k)
      std::copy_n(from.begin() + static_cast<long>((k % set.n) * per_state), per_state,
                  to.begin() + static_cast<long>(k * per_state));
  };
  take(set.q, nv, s.q);
  take(set.qd, nv, s.qd);
  take(set.tau, nv, s.tau);
  take(set.dqdd_dq, nv * nv, s.dqdd_dq);
  take(set.dqdd_dqd, nv * nv, s.dqdd_dqd);
  return s;
}

}  // namespace rbdgrad::bench
