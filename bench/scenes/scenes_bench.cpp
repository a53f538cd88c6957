// Benchmarks for the execution plan's skips (issue 8, scenes): the forward-dynamics gradient
// (fd_derivatives, tau input) per state, for the full computation and for each stage a scene can
// skip, on iiwa14, talos_reduced and hyq, in f64 and f32.
//
// Variants (the full computation: both d qdd columns, gravity, forces on every body, M^-1 computed):
//   full, dq_only (d qdd/d q alone), dqd_only (d qdd/d qd alone), cached_minv (M^-1 supplied),
//   no_gravity, no_fext (no external forces), fext_feet (forces on the feet only: iiwa14's last
//   link, talos_reduced's two feet, hyq's four lower legs), locked (talos_reduced with its head,
//   grippers and wrists locked: 22 joints instead of 32; the full computation on the reduced model).
// Each benchmark times three ways in turn, one pass over the state pool each, in rotating order,
// so that the machine's noise (a 2-core VM) falls on all three alike:
//   full:   the full computation through its plan (on talos_reduced's 32 joints for `locked`);
//   plan:   the variant through fd_derivatives with its ExecutionPlan, built once as a scene's
//           (the plan is checked and the specialized instantiation selected on every call);
//   direct: that instantiation, fd_derivatives_specialized<stages>, called directly: the build
//           that never had the skipped stages (its code has none of them).
// Counters, ns per state: full_ns, plan_ns, direct_ns; ratios: speedup = full / plan (what the skip
// brings), plan_over_direct = plan / direct (what selecting it through the plan costs).
// Names: "<robot>/<f64|f32>/<variant>". The states rotate through a pool of 64 seeded random states
// (q within the joint limits, qd within +-2, tau within the effort limits, forces within +-5 N and
// N m per body); the benchmark's own Time column is per pass of the three (3 x 64 states).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "../../tests/support/test_models.hpp"
#include "../support/rotating_ways.hpp"
#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using namespace rbdgrad;

constexpr int kPoolSize = 64;  // power of two: the rotating index is a mask
constexpr unsigned kSeed = 20240801;
// put in front of the command line, so that any can be overridden there; repetitions interleaved
// at random across benchmarks
constexpr const char* kDefaultFlags[] = {
    "--benchmark_min_time=0.2",
    "--benchmark_repetitions=5",
    "--benchmark_report_aggregates_only=true",
    "--benchmark_enable_random_interleaving=true",
};

enum class Variant { kFull, kDqOnly, kDqdOnly, kCachedMinv, kNoGravity, kNoFext, kFextFeet, kLocked };

const char* variant_name(Variant v) {
  switch (v) {
    case Variant::kFull: return "full";
    case Variant::kDqOnly: return "dq_only";
    case Variant::kDqdOnly: return "dqd_only";
    case Variant::kCachedMinv: return "cached_minv";
    case Variant::kNoGravity: return "no_gravity";
    case Variant::kNoFext: return "no_fext";
    case Variant::kFextFeet: return "fext_feet";
    case Variant::kLocked: return "locked";
  }
  return "?";
}

// The stages compiled into a variant's instantiation.
constexpr GradientStages stages_of(Variant v) {
  switch (v) {
    case Variant::kDqOnly: return {true, false, true};
    case Variant::kDqdOnly: return {false, true, true};
    case Variant::kNoFext: return {true, true, false};
    default: return kAllStages;
  }
}

struct StateD {
  Eigen::VectorXd q, qd, tau, fext;  // fext: 6 x nv, every body
  Eigen::MatrixXd Minv;              // M^-1(q), the cached_minv variant's
};

template <class S>
struct StateS {
  VectorX<S> q, qd, tau, fext;
  MatrixX<S> Minv;
};

struct Robot {
  std::string name;
  Model model;
  BodyMask feet;
  std::vector<StateD> pool;
};

Model load(std::string_view name) {
  Model m;
  Status s = load_urdf_string(std::string(embedded_robot_urdf(name)), std::string(name), m);
  if (!s) {
    std::fprintf(stderr, "scenes_bench: cannot load %s: %s\n", std::string(name).c_str(), s.to_string().c_str());
    std::exit(1);
  }
  return m;
}

// the bodies a foot contact pushes on: hyq's lower legs, talos's last leg links, iiwa14's last link
BodyMask feet_of(const Model& m) {
  BodyMask feet;
  for (int i = 0; i < m.nv; ++i) {
    const std::string& n = m.joints[static_cast<std::size_t>(i)].name;
    if (n.ends_with("_kfe_joint") || (n.starts_with("leg") && n.ends_with("_6_joint"))) feet.set(i);
  }
  if (feet.empty()) feet.set(m.nv - 1);
  return feet;
}

// Seeded random states that the full computation evaluates in f64 and f32.
std::vector<StateD> make_pool(const Model& m) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const int n = m.nv;
  Workspace ws(m);
  const ModelTpl<float> mf = m.cast<float>();
  WorkspaceTpl<float> wf(mf);
  std::vector<StateD> pool;
  int rejected = 0;
  while (static_cast<int>(pool.size()) < kPoolSize) {
    StateD st;
    st.q.resize(n);
    st.qd.resize(n);
    st.tau.resize(n);
    st.fext.resize(6 * n);
    for (int i = 0; i < n; ++i) {
      const JointInfo& j = m.joints[static_cast<std::size_t>(i)];
      const bool limited = j.lower_limit != 0 || j.upper_limit != 0;
      const double lo = limited ? j.lower_limit : -std::numbers::pi, hi = limited ? j.upper_limit : std::numbers::pi;
      st.q(i) = lo + (hi - lo) * (0.5 + 0.5 * unit(rng));
      st.qd(i) = 2.0 * unit(rng);
      st.tau(i) = (j.effort_limit > 0 ? j.effort_limit : 10.0) * unit(rng);
    }
    for (int k = 0; k < 6 * n; ++k) st.fext(k) = 5.0 * unit(rng);
    const bool ok = fd_derivatives(m, ws, st.q, st.qd, st.tau, InputKind::kTau, st.fext.data()) &&
                    fd_derivatives(mf, wf, st.q.cast<float>(), st.qd.cast<float>(), st.tau.cast<float>(),
                                   InputKind::kTau, st.fext.cast<float>().eval().data());
    if (!ok) {
      if (++rejected > 100 * kPoolSize) std::exit(1);
      continue;
    }
    if (!minverse(m, ws, st.q)) std::exit(1);
    st.Minv = ws.Minv;
    pool.push_back(std::move(st));
  }
  return pool;
}

Robot make_robot(std::string_view name, const Model& model) {
  Robot r{std::string(name), model, feet_of(model), {}};
  r.pool = make_pool(r.model);
  return r;
}

// The plan a scene of this variant would register.
ExecutionPlan plan_of(Variant v, const Robot& r) {
  ExecutionPlan p;
  p.external_forces = ExternalForces::kAllBodies;
  switch (v) {
    case Variant::kDqOnly: p.dqdd_dqd = false; break;
    case Variant::kDqdOnly: p.dqdd_dq = false; break;
    case Variant::kCachedMinv: p.minv_supplied = true; break;
    case Variant::kNoGravity: p.gravity = false; break;
    case Variant::kNoFext: p.external_forces = ExternalForces::kNone; break;
    case Variant::kFextFeet:
      p.external_forces = ExternalForces::kSomeBodies;
      p.fext_bodies = r.feet;
      break;
    default: break;
  }
  return p;
}

template <class S>
std::vector<StateS<S>> cast_pool(const std::vector<StateD>& pool) {
  std::vector<StateS<S>> out;
  for (const StateD& st : pool)
    out.push_back({st.q.cast<S>(), st.qd.cast<S>(), st.tau.cast<S>(), st.fext.cast<S>(), st.Minv.cast<S>()});
  return out;
}

template <Variant kVariant, bool kDirect, class S>
inline Status run_one(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const StateS<S>& st, const ExecutionPlan& plan) {
  const MatrixX<S>* minv = plan.minv_supplied ? &st.Minv : nullptr;
  if constexpr (kDirect) {
    return fd_derivatives_specialized<stages_of(kVariant), S>(m, ws, st.q, st.qd, st.tau, InputKind::kTau,
                                                              plan.gravity, st.fext.data(), forced_bodies(plan), minv);
  } else {
    return fd_derivatives(m, ws, st.q, st.qd, st.tau, InputKind::kTau, plan, st.fext.data(), minv);
  }
}

// One robot in S: its model, workspace and pool, run under one plan.
template <class S>
struct Runner {
  Runner(const Robot& r, const ExecutionPlan& p)
      : m(r.model.template cast<S>()), ws(m), pool(cast_pool<S>(r.pool)), plan(p) {}

  // one pass over the pool, through the plan or the specialized instantiation
  template <Variant kVariant, bool kDirect>
  Status pass() {
    Status result;
    for (const StateS<S>& st : pool) {
      Status s = run_one<kVariant, kDirect, S>(m, ws, st, plan);
      benchmark::DoNotOptimize(ws.dqdd_dq.data());
      benchmark::DoNotOptimize(ws.dqdd_dqd.data());
      benchmark::ClobberMemory();
      if (!s && result) result = std::move(s);
    }
    return result;
  }

  ModelTpl<S> m;
  WorkspaceTpl<S> ws;
  std::vector<StateS<S>> pool;
  ExecutionPlan plan;
};

template <Variant kVariant, class S>
void bench(benchmark::State& state, const Robot* robot, const Robot* full_robot) {
  Runner<S> full(*full_robot, plan_of(Variant::kFull, *full_robot)), variant(*robot, plan_of(kVariant, *robot));
  if (gradient_stages(variant.plan) != stages_of(kVariant)) {
    state.SkipWithError("the plan's stages are not the variant's");
    return;
  }
  // every pool state once each way, untimed: the Status is checked here and not in the timed loop
  for (Status s : {full.template pass<Variant::kFull, false>(), variant.template pass<kVariant, false>(),
                   variant.template pass<kVariant, true>()}) {
    if (!s) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
  }
  long passes = 0;
  // full, plan, direct
  const std::array<double, 3> ns = bench::time_rotating_ways<3>(
      state,
      [&](int which) {
        Status s = which == 0   ? full.template pass<Variant::kFull, false>()
                   : which == 1 ? variant.template pass<kVariant, false>()
                                : variant.template pass<kVariant, true>();
        benchmark::DoNotOptimize(s);
      },
      passes);
  bench::report_three_ways(state, ns, static_cast<double>(passes) * kPoolSize, {"full", "plan", "direct"});
  state.SetLabel("nv=" + std::to_string(variant.m.nv));
}

template <Variant kVariant, class S>
void register_variant(const Robot* robot, const Robot* full_robot) {
  const std::string name = full_robot->name + "/" + scalar_name<S>() + "/" + variant_name(kVariant);
  benchmark::RegisterBenchmark(name.c_str(), bench<kVariant, S>, robot, full_robot)->Unit(benchmark::kMicrosecond);
}

template <class S>
void register_robot(const Robot* robot) {
  register_variant<Variant::kFull, S>(robot, robot);
  register_variant<Variant::kDqOnly, S>(robot, robot);
  register_variant<Variant::kDqdOnly, S>(robot, robot);
  register_variant<Variant::kCachedMinv, S>(robot, robot);
  register_variant<Variant::kNoGravity, S>(robot, robot);
  register_variant<Variant::kNoFext, S>(robot, robot);
  register_variant<Variant::kFextFeet, S>(robot, robot);
}

}  // namespace

int main(int argc, char** argv) {
  // models and pools live until the end of main: the benchmarks point into them
  std::vector<Robot> robots;
  for (std::string_view name : {"iiwa14", "talos_reduced", "hyq"}) robots.push_back(make_robot(name, load(name)));
  const Model& talos = robots[1].model;
  Model locked;
  if (Status s = lock_joints(talos, testing::talos_hands_and_head(talos), locked); !s) {
    std::fprintf(stderr, "scenes_bench: %s\n", s.to_string().c_str());
    return 1;
  }
  robots.push_back(make_robot("talos_reduced", locked));  // its pool: states of the 22 kept joints

  for (std::size_t r = 0; r < 3; ++r) {
    register_robot<double>(&robots[r]);
    register_robot<float>(&robots[r]);
  }
  register_variant<Variant::kLocked, double>(&robots[3], &robots[1]);
  register_variant<Variant::kLocked, float>(&robots[3], &robots[1]);

  std::vector<char*> args{argv[0]};
  for (const char* f : kDefaultFlags) args.push_back(const_cast<char*>(f));
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  int n_args = static_cast<int>(args.size());
  args.push_back(nullptr);
  benchmark::Initialize(&n_args, args.data());
  if (benchmark::ReportUnrecognizedArguments(n_args, args.data())) return 1;
  std::string locked_names;
  for (const LockedJoint& l : testing::talos_hands_and_head(talos))
    locked_names += (locked_names.empty() ? "" : " ") + l.name;
  benchmark::AddCustomContext("talos_reduced_locked", locked_names);
  for (const Robot& r : robots) {
    std::string feet;
    r.feet.for_each(r.model.nv, [&](int b) {
      feet += (feet.empty() ? "" : " ") + r.model.joints[static_cast<std::size_t>(b)].name;
    });
    benchmark::AddCustomContext("feet_" + r.name + "_nv" + std::to_string(r.model.nv), feet);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
