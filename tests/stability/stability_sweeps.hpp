// The numerical-stability sweeps (issue 7) as a list of points, each a model and a way to draw
// states, and how one point is run in every precision. The fast tests and the long sweeps differ
// only in their grid.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "precision_run.hpp"

namespace rbdgrad::stability {

// The precisions measured, in this order in every Sample.
inline constexpr int kNumPrecisions = 3;
inline const char* const kPrecisionNames[kNumPrecisions] = {scalar_name<double>(), scalar_name<float>(),
                                                            scalar_name<Q16_16>()};

struct Sample {
  bool reference_ok = false;  // errors are measured only where the long double reference succeeded
  double cond = 0;            // cond(M(q)) when reference_ok
  Outcome outcome[kNumPrecisions];
};

// The speed of the joints wherever velocity is not what is swept (rad/s or m/s).
inline constexpr double kNominalSpeed = 1.0;

struct PointSpec {
  std::string sweep;  // velocity, mass_ratio, inertia_ratio, joint_limit, singularity, joints
  std::string robot;
  bool gravity = true;
  double x = 0;  // the swept quantity
  int models = 1;  // the point's states are spread over this many model variants
  std::function<Model(int variant)> model;
  std::function<StateInput(const Model&, std::mt19937&)> state;
};

struct Point {
  PointSpec spec;
  std::vector<Sample> samples;
};

struct SweepGrid {
  int states_per_point = 8;
  int speed_points_per_decade = 1;
  int ratio_points_per_decade = 1;  // link mass and inertia ratios
  std::vector<std::string> robots;  // embedded robots, "chain64", "tree64" (random 64-joint models)
  std::vector<int> joint_counts;    // the joints sweep: random chains and trees of these sizes
  int models_per_count = 2;
  std::vector<double> limit_fractions;      // distance to the limit, as a fraction of the range
  std::vector<double> singularity_offsets;  // size of the perturbation of q = 0 on iiwa14
  std::vector<bool> gravity = {true, false};
};

// lo, ..., hi with `per_decade` points per decade (lo and hi powers of ten)
inline std::vector<double> log_grid(double lo, double hi, int per_decade) {
  std::vector<double> x;
  const int steps = static_cast<int>(std::lround(std::log10(hi / lo) * per_decade));
  for (int k = 0; k <= steps; ++k) x.push_back(lo * std::pow(10.0, static_cast<double>(k) / per_decade));
  return x;
}

inline Model robot_model(const std::string& name) {
  if (name == "chain64") return testing::random_model(64, 64, testing::TreeShape::kChain);
  if (name == "tree64") return testing::random_model(65, 64, testing::TreeShape::kBranching);
  return testing::load_embedded(name);
}

// Random configuration, the fastest joint at `speed`, controller-like torques.
inline StateInput random_state(const Model& m, std::mt19937& rng, double speed) {
  StateInput s;
  s.q = random_configuration(m, rng);
  s.qd = velocity_with_max(rng, m.nv, speed);
  s.tau = torque_for_moderate_acceleration(m, rng, s.q, s.qd);
  return s;
}

inline std::vector<PointSpec> stability_plan(const SweepGrid& g) {
  std::vector<PointSpec> plan;
  auto add = [&](PointSpec p) {
    for (bool gravity : g.gravity) {
      p.gravity = gravity;
      plan.push_back(p);
    }
  };
  for (const std::string& robot : g.robots) {
    const Model base = robot_model(robot);
    auto fixed_model = [base](int) { return base; };
    for (double speed : log_grid(0.01, 100, g.speed_points_per_decade))
      add({"velocity", robot, true, speed, 1, fixed_model,
           [speed](const Model& m, std::mt19937& rng) { return random_state(m, rng, speed); }});
    for (Scaling what : {Scaling::kMassAndInertia, Scaling::kInertia})
      for (double ratio : log_grid(1e-4, 1e4, g.ratio_points_per_decade))
        add({what == Scaling::kMassAndInertia ? "mass_ratio" : "inertia_ratio", robot, true, ratio, 1,
             [base, ratio, what](int) { return with_link_ratio(base, ratio, what); },
             [](const Model& m, std::mt19937& rng) { return random_state(m, rng, kNominalSpeed); }});
    bool limited = false;
    for (const JointInfo& j : base.joints) limited = limited || has_limits(j);
    if (limited)
      for (double fraction : g.limit_fractions)
        add({"joint_limit", robot, true, fraction, 1, fixed_model, [fraction](const Model& m, std::mt19937& rng) {
               StateInput s;
               s.q = configuration_near_limits(m, rng, fraction);
               s.qd = velocity_with_max(rng, m.nv, kNominalSpeed);
               s.tau = torque_for_moderate_acceleration(m, rng, s.q, s.qd);
               return s;
             }});
    if (robot == "iiwa14")
      for (double eps : g.singularity_offsets)
        add({"singularity", robot, true, eps, 1, fixed_model, [eps](const Model& m, std::mt19937& rng) {
               StateInput s;
               s.q = configuration_near_zero(rng, m.nv, eps);
               s.qd = velocity_with_max(rng, m.nv, kNominalSpeed);
               s.tau = torque_for_moderate_acceleration(m, rng, s.q, s.qd);
               return s;
             }});
  }
  for (testing::TreeShape shape : {testing::TreeShape::kChain, testing::TreeShape::kBranching})
    for (int n : g.joint_counts)
      add({"joints", shape == testing::TreeShape::kChain ? "random_chain" : "random_tree", true,
           static_cast<double>(n), g.models_per_count,
           [n, shape](int k) { return testing::random_model(static_cast<unsigned>(1000 + 16 * n + k), n, shape); },
           [](const Model& m, std::mt19937& rng) { return random_state(m, rng, kNominalSpeed); }});
  return plan;
}

// Runs `states` states of one point in long double (the reference) and in every precision.
inline Point run_point(const PointSpec& spec, int states, unsigned seed) {
  Point p{spec, {}};
  std::mt19937 rng(seed);
  for (int v = 0; v < spec.models; ++v) {
    const Model m = with_gravity(spec.model(v), spec.gravity);
    ReferenceRun reference(m);
    PrecisionRun<double> f64(m);
    PrecisionRun<float> f32(m);
    PrecisionRun<Q16_16> fixed(m);
    const int count = states / spec.models + (v < states % spec.models ? 1 : 0);
    for (int k = 0; k < count; ++k) {
      const StateInput s = spec.state(m, rng);
      Sample sample;
      const Reference ref = reference.run(s);
      sample.reference_ok = ref.ok;
      sample.cond = ref.cond;
      sample.outcome[0] = f64.run(s, ref);
      sample.outcome[1] = f32.run(s, ref);
      sample.outcome[2] = fixed.run(s, ref);
      p.samples.push_back(std::move(sample));
    }
  }
  return p;
}

// Median and worst of the measured errors of one precision over some samples (the states not
// flagged).
struct ErrorSummary {
  int states = 0;
  int measured = 0;         // states not flagged whose reference succeeded
  int flagged = 0;          // states refused: non-ok Status or fixed-point overflow
  int silent_failures = 0;  // NaN, Inf or saturated outputs not flagged (must stay 0)
  int wrong = 0;            // measured states with a relative error above 1: finite, unflagged and useless
  double median_dq = std::nan(""), worst_dq = std::nan(""), median_dqd = std::nan(""), worst_dqd = std::nan("");

  double median() const { return std::fmax(median_dq, median_dqd); }
  double worst() const { return std::fmax(worst_dq, worst_dqd); }
};

inline ErrorSummary summarize(const std::vector<const Sample*>& samples, int precision) {
  ErrorSummary e;
  std::vector<double> dq, dqd;
  for (const Sample* s : samples) {
    const Outcome& o = s->outcome[precision];
    ++e.states;
    e.flagged += o.flagged;
    e.silent_failures += o.silent_failure();
    if (o.flagged || !s->reference_ok) continue;
    ++e.measured;
    e.wrong += o.error() > 1;
    dq.push_back(o.err_dq);
    dqd.push_back(o.err_dqd);
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return std::nan("");
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  auto worst = [](const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end()); };
  e.median_dq = median(dq);
  e.median_dqd = median(dqd);
  e.worst_dq = worst(dq);
  e.worst_dqd = worst(dqd);
  return e;
}

inline ErrorSummary summarize(const Point& p, int precision) {
  std::vector<const Sample*> all;
  for (const Sample& s : p.samples) all.push_back(&s);
  return summarize(all, precision);
}

}  // namespace rbdgrad::stability
