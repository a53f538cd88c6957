// Benchmarks for core/src/algorithm/*.cpp.
//
// Time per state of rnea, crba, minverse, forward_dynamics, rnea_derivatives, fd_derivatives (tau
// input, M^-1 computed) and fd_derivatives with a caller-supplied M^-1, for every embedded robot, in
// f64 and f32 (and Q16.16 fixed point for the two fd_derivatives variants).
//
// Names: "<algorithm>/<robot>/<f64|f32|fixed>", e.g. fd_derivatives/iiwa14/f64,
// fd_derivatives_supplied_minv/panda/f32. One iteration = one state; the states rotate through a pool
// of 64 seeded random states so that caches and branch predictors see varied data.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rbdgrad/algorithm/crba.hpp"
#include "rbdgrad/algorithm/fd_derivatives.hpp"
#include "rbdgrad/algorithm/forward_dynamics.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/algorithm/rnea.hpp"
#include "rbdgrad/algorithm/rnea_derivatives.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "rbdgrad/urdf.hpp"
#include "rbdgrad/workspace.hpp"

namespace {

using namespace rbdgrad;

constexpr int kPoolSize = 64;  // power of two: the rotating index is a mask
constexpr unsigned kSeed = 20240601;
// Defaults put in front of the command line (so any of them can be overridden there): 0.2 s per
// repetition, 5 repetitions, only mean/median/stddev/cv reported. A full run takes about 1-2 minutes.
constexpr const char* kDefaultFlags[] = {
    "--benchmark_min_time=0.2",
    "--benchmark_repetitions=5",
    "--benchmark_report_aggregates_only=true",
};

// One random state in double, with the quantities every algorithm needs as input.
struct StateD {
  Eigen::VectorXd q, qd, tau, qdd;  // qdd = FD(q, qd, tau)
  Eigen::MatrixXd Minv;             // M^-1(q), for the supplied-M^-1 variant
};

template <class S>
struct StateS {
  VectorX<S> q, qd, tau, qdd;
  MatrixX<S> Minv;
};

struct Robot {
  std::string name;
  Model model;
  std::vector<StateD> pool;
  int rejected = 0;  // random draws rejected because some precision could not evaluate them
};

// A state is valid when every benchmarked precision evaluates it without error (finite results in
// floating point, no saturation in Q16.16): forward dynamics in f64 and f32 and fd_derivatives in all
// three precisions. Random tau within the effort limits can demand accelerations of a light distal
// link that Q16.16 cannot represent; such draws are redrawn.
template <class S>
bool valid_in(const Model& md, const StateD& st) {
  const ModelTpl<S> m = md.template cast<S>();
  WorkspaceTpl<S> ws(m);
  const VectorX<S> q = st.q.cast<S>(), qd = st.qd.cast<S>(), tau = st.tau.cast<S>();
  if constexpr (!is_fixed_point_v<S>) {
    if (!forward_dynamics(m, ws, q, qd, tau)) return false;
    if (!minverse(m, ws, q)) return false;
  }
  return static_cast<bool>(fd_derivatives(m, ws, q, qd, tau, InputKind::kTau));
}

Robot make_robot(std::string_view name) {
  Robot r;
  r.name = std::string(name);
  Status s = load_urdf_string(std::string(embedded_robot_urdf(name)), r.name, r.model);
  if (!s) {
    std::fprintf(stderr, "core_bench: cannot load %s: %s\n", r.name.c_str(), s.to_string().c_str());
    std::exit(1);
  }
  const Model& m = r.model;
  const int n = m.nv;
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Workspace ws(m);
  while (static_cast<int>(r.pool.size()) < kPoolSize) {
    StateD st;
    st.q.resize(n);
    st.qd.resize(n);
    st.tau.resize(n);
    for (int i = 0; i < n; ++i) {
      const JointInfo& j = m.joints[static_cast<size_t>(i)];
      const bool limited = j.lower_limit != 0 || j.upper_limit != 0;
      const double lo = limited ? j.lower_limit : -std::numbers::pi;
      const double hi = limited ? j.upper_limit : std::numbers::pi;
      st.q(i) = lo + (hi - lo) * (0.5 + 0.5 * unit(rng));
      st.qd(i) = 2.0 * unit(rng);
      st.tau(i) = (j.effort_limit > 0 ? j.effort_limit : 10.0) * unit(rng);
    }
    if (!valid_in<double>(m, st) || !valid_in<float>(m, st) || !valid_in<Q16_16>(m, st)) {
      if (++r.rejected > 100 * kPoolSize) {
        std::fprintf(stderr, "core_bench: %s: cannot draw %d valid states\n", r.name.c_str(), kPoolSize);
        std::exit(1);
      }
      continue;
    }
    if (!forward_dynamics(m, ws, st.q, st.qd, st.tau) || !minverse(m, ws, st.q)) std::exit(1);
    st.qdd = ws.qdd;
    st.Minv = ws.Minv;
    r.pool.push_back(std::move(st));
  }
  return r;
}

template <class S>
std::vector<StateS<S>> cast_pool(const std::vector<StateD>& pool) {
  std::vector<StateS<S>> out;
  out.reserve(pool.size());
  for (const StateD& st : pool)
    out.push_back({st.q.cast<S>(), st.qd.cast<S>(), st.tau.cast<S>(), st.qdd.cast<S>(), st.Minv.cast<S>()});
  return out;
}

enum class Algo { kRnea, kCrba, kMinverse, kForwardDynamics, kRneaDerivatives, kFdDerivatives, kFdDerivativesMinv };

const char* algo_name(Algo a) {
  switch (a) {
    case Algo::kRnea: return "rnea";
    case Algo::kCrba: return "crba";
    case Algo::kMinverse: return "minverse";
    case Algo::kForwardDynamics: return "forward_dynamics";
    case Algo::kRneaDerivatives: return "rnea_derivatives";
    case Algo::kFdDerivatives: return "fd_derivatives";
    case Algo::kFdDerivativesMinv: return "fd_derivatives_supplied_minv";
  }
  return "?";
}

// One call of `algo` on state `st`; the outputs it writes are passed to DoNotOptimize.
template <Algo A, class S>
inline Status run_one(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const StateS<S>& st) {
  if constexpr (A == Algo::kRnea) {
    Status s = rnea(m, ws, st.q, st.qd, st.qdd);
    benchmark::DoNotOptimize(ws.tau.data());
    return s;
  } else if constexpr (A == Algo::kCrba) {
    Status s = crba(m, ws, st.q);
    benchmark::DoNotOptimize(ws.M.data());
    return s;
  } else if constexpr (A == Algo::kMinverse) {
    Status s = minverse(m, ws, st.q);
    benchmark::DoNotOptimize(ws.Minv.data());
    return s;
  } else if constexpr (A == Algo::kForwardDynamics) {
    Status s = forward_dynamics(m, ws, st.q, st.qd, st.tau);
    benchmark::DoNotOptimize(ws.qdd.data());
    return s;
  } else if constexpr (A == Algo::kRneaDerivatives) {
    Status s = rnea_derivatives(m, ws, st.q, st.qd, st.qdd);
    benchmark::DoNotOptimize(ws.dtau_dq.data());
    benchmark::DoNotOptimize(ws.dtau_dqd.data());
    return s;
  } else if constexpr (A == Algo::kFdDerivatives) {
    Status s = fd_derivatives(m, ws, st.q, st.qd, st.tau, InputKind::kTau);
    benchmark::DoNotOptimize(ws.dqdd_dq.data());
    benchmark::DoNotOptimize(ws.dqdd_dqd.data());
    return s;
  } else {
    Status s = fd_derivatives(m, ws, st.q, st.qd, st.tau, InputKind::kTau, static_cast<const S*>(nullptr),
                              &st.Minv);
    benchmark::DoNotOptimize(ws.dqdd_dq.data());
    benchmark::DoNotOptimize(ws.dqdd_dqd.data());
    return s;
  }
}

template <Algo A, class S>
void bench(benchmark::State& state, const Robot* robot) {
  const ModelTpl<S> m = robot->model.template cast<S>();
  WorkspaceTpl<S> ws(m);
  const std::vector<StateS<S>> pool = cast_pool<S>(robot->pool);
  // every pool state once, untimed: the Status is checked here and not in the timed loop
  for (size_t k = 0; k < pool.size(); ++k) {
    if constexpr (is_fixed_point_v<S>) FixedPointStatus::clear();
    Status s = run_one<A, S>(m, ws, pool[k]);
    if (!s) {
      state.SkipWithError(("state " + std::to_string(k) + ": " + s.to_string()).c_str());
      return;
    }
  }
  unsigned k = 0;
  for (auto _ : state) {
    Status s = run_one<A, S>(m, ws, pool[k]);
    benchmark::DoNotOptimize(s);
    benchmark::ClobberMemory();
    k = (k + 1) & (kPoolSize - 1);
  }
  state.SetItemsProcessed(state.iterations());  // items_per_second = states per second
  state.SetLabel("nv=" + std::to_string(m.nv));
}

template <Algo A, class S>
void register_one(const Robot* robot) {
  const std::string name = std::string(algo_name(A)) + "/" + robot->name + "/" + scalar_name<S>();
  benchmark::RegisterBenchmark(name.c_str(), bench<A, S>, robot)
      ->Unit(benchmark::kNanosecond);
}

template <Algo A>
void register_float_types(const Robot* robot) {
  register_one<A, double>(robot);
  register_one<A, float>(robot);
}

}  // namespace

int main(int argc, char** argv) {
  // models and state pools live until the end of main: the benchmarks point into them
  std::vector<Robot> robots;
  for (std::string_view name : {"iiwa14", "panda", "talos_reduced", "hyq"}) robots.push_back(make_robot(name));

  for (const Robot& r : robots) {
    register_float_types<Algo::kRnea>(&r);
    register_float_types<Algo::kCrba>(&r);
    register_float_types<Algo::kMinverse>(&r);
    register_float_types<Algo::kForwardDynamics>(&r);
    register_float_types<Algo::kRneaDerivatives>(&r);
    register_float_types<Algo::kFdDerivatives>(&r);
    register_one<Algo::kFdDerivatives, Q16_16>(&r);
    register_float_types<Algo::kFdDerivativesMinv>(&r);
    register_one<Algo::kFdDerivativesMinv, Q16_16>(&r);
  }

  std::vector<char*> args{argv[0]};
  for (const char* f : kDefaultFlags) args.push_back(const_cast<char*>(f));
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  int n_args = static_cast<int>(args.size());
  args.push_back(nullptr);
  benchmark::Initialize(&n_args, args.data());
  if (benchmark::ReportUnrecognizedArguments(n_args, args.data())) return 1;
  for (const Robot& r : robots)
    benchmark::AddCustomContext("pool_" + r.name,
                                std::to_string(kPoolSize) + " states (seed " + std::to_string(kSeed) + ", " +
                                    std::to_string(r.rejected) + " draws rejected)");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
