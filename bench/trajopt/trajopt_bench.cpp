// trajopt_bench: what a backend's gradient error does to a controller (issue 7). iLQR moves the
// iiwa14 from rest to rest (reach_task.hpp) with the rollouts in f64 in-process and the
// linearization from rbdgradd, one batched request per iteration, once per backend and precision —
// and from the FPGA kernel's arithmetic in-process in each fixed-point format it is built for
// (kernel_linearizer.hpp), which the daemon does not serve; it reports iterations, final cost, goal
// error and times per run. run_trajopt.sh starts a daemon and runs it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "args.hpp"
#include "arm_plant.hpp"
#include "daemon_linearizer.hpp"
#include "ilqr.hpp"
#include "kernel_linearizer.hpp"
#include "model_source.hpp"
#include "rbdgrad/client.hpp"
#include "reach_task.hpp"
#include "run_report.hpp"

namespace {

using namespace rbdgrad;
using namespace rbdgrad::trajopt;

constexpr cli::OptionSpec kOptions[] = {
    {"server", "ADDR", "the daemon: HOST:PORT or unix:PATH; default 127.0.0.1:50051"},
    {"runs", "LIST", "backend:precision pairs, e.g. cpu:f64,cpu:f32,cpu:fixed,fpga:fixed,cuda:f64, and kernel:FORMAT "
                     "for the FPGA kernel in-process (Q20.12, Q16.16, Q12.20, Q24.24); default every ready backend "
                     "in each precision it reports, then every kernel format"},
    {"csv", "PATH", "also write one CSV row per run there"},
    {"markdown", "PATH", "also write the Markdown table and one line per run there"},
    {"quick", "", "a smoke test: 50 steps, at most 10 iterations"},
    {"max-iterations", "N", "iLQR iterations at most; default 100 (10 with --quick)"},
    {"tolerance", "REL", "converged when an iteration lowers the cost by less than this fraction; default 1e-6"},
    {"help", "", "show this help"},
};

constexpr const char* kModel = "iiwa14";

// One run: a backend and precision through the daemon, or a fixed-point format of the kernel
// in-process.
struct RunSpec {
  bool kernel = false;
  Backend backend{};
  Precision precision{};
  bench::FixedFormat format;  // kernel only

  std::string name() const {
    return kernel ? "kernel:" + format.name : std::string(backend_name(backend)) + ":" + precision_name(precision);
  }
};

struct Options {
  std::string server = std::string(kDefaultServerAddress);
  std::vector<RunSpec> runs;  // empty = all the daemon offers, then every kernel format
  std::string csv, markdown;
  bool quick = false;
  IlqrOptions ilqr;
};

int usage_error(const std::string& message) {
  std::cerr << "trajopt_bench: " << message << "\nusage: trajopt_bench [--server ADDR] [--runs LIST] [options] "
               "(see --help)\n";
  return 2;
}

std::string parse_options(const cli::Args& args, Options& o) {
  o.server = args.value_or("server", o.server);
  o.csv = args.value_or("csv", "");
  o.markdown = args.value_or("markdown", "");
  o.quick = args.has("quick");
  o.ilqr.max_iterations = o.quick ? 10 : 100;
  if (const std::string* list = args.value("runs")) {
    for (const std::string& item : cli::split_list(*list)) {
      const std::size_t colon = item.find(':');
      RunSpec run;
      if (colon != std::string::npos && item.substr(0, colon) == "kernel") {
        const std::string name = item.substr(colon + 1);
        const auto& formats = bench::fixed_formats();
        const auto f = std::find_if(formats.begin(), formats.end(), [&](const auto& x) { return x.name == name; });
        if (f == formats.end()) return "--runs: '" + item + "': the kernel has Q20.12, Q16.16, Q12.20 and Q24.24";
        run.kernel = true;
        run.format = *f;
      } else if (colon == std::string::npos || !parse_backend(item.substr(0, colon), run.backend) ||
                 run.backend == Backend::kAuto || !parse_precision(item.substr(colon + 1), run.precision) ||
                 run.precision == Precision::kAuto) {
        return "--runs: '" + item + "' is not BACKEND:PRECISION (cpu|cuda|fpga : f64|f32|fixed) or kernel:FORMAT";
      }
      o.runs.push_back(std::move(run));
    }
    if (o.runs.empty()) return "--runs is empty";
  }
  if (const std::string* n = args.value("max-iterations")) {
    try {
      std::size_t end = 0;
      o.ilqr.max_iterations = std::stoi(*n, &end);
      if (end != n->size() || o.ilqr.max_iterations < 1) throw std::invalid_argument(*n);
    } catch (const std::exception&) {
      return "--max-iterations: '" + *n + "' is not a positive integer";
    }
  }
  if (const std::string* t = args.value("tolerance")) {
    try {
      std::size_t end = 0;
      o.ilqr.tolerance = std::stod(*t, &end);
      if (end != t->size() || !(o.ilqr.tolerance > 0)) throw std::invalid_argument(*t);
    } catch (const std::exception&) {
      return "--tolerance: '" + *t + "' is not a positive number";
    }
  }
  return "";
}

// Whether `backend` is ready and computes in `precision`; "" or why not.
std::string unavailable_reason(const ServerInfo& info, Backend backend, Precision precision) {
  for (const BackendStatus& b : info.backends) {
    if (b.backend != backend) continue;
    if (!b.ready) return std::string(backend_name(backend)) + " is not available: " + b.reason;
    for (Precision p : b.precisions)
      if (p == precision) return "";
    return std::string(backend_name(backend)) + " does not compute in " + precision_name(precision);
  }
  return std::string("the daemon has no ") + backend_name(backend) + " backend";
}

// The final state against the goal and the limits.
void assess(const ReachTask& task, const ModelDescription& model, const Trajectory& t, RunRecord& r) {
  const Eigen::Index n = task.q_goal.size();
  r.q_error = (t.x.back().head(n) - task.q_goal).norm();
  r.qd_error = t.x.back().tail(n).norm();
  r.reached = r.q_error < task.goal_q_tol && r.qd_error < task.goal_qd_tol;
  for (Eigen::Index j = 0; j < n; ++j) {
    const JointDescription& joint = model.joints[static_cast<std::size_t>(j)];
    for (std::size_t k = 0; k < t.x.size(); ++k) {
      const double q = t.x[k](j), qd = t.x[k](n + j);
      if (joint.has_position_limits() && (q < joint.lower_limit || q > joint.upper_limit))
        r.within_position_limits = false;
      if (joint.velocity_limit > 0) r.max_qd_ratio = std::max(r.max_qd_ratio, std::abs(qd) / joint.velocity_limit);
      if (k < t.u.size() && joint.effort_limit > 0)
        r.max_tau_ratio = std::max(r.max_tau_ratio, std::abs(t.u[k](j)) / joint.effort_limit);
    }
  }
}

RunRecord run_one(const Client& client, const Model& model, const ModelDescription& description,
                  const ReachTask& task, const IlqrOptions& ilqr, const RunSpec& run) {
  RunRecord r;
  // the kernel's rows are named as the accuracy benchmark names them
  r.backend = run.kernel ? "fpga kernel" : backend_name(run.backend);
  r.precision = run.kernel ? run.format.name : precision_name(run.precision);
  ArmPlant plant(model, task.dt), reference(model, task.dt);
  const QuadraticCost cost = reach_cost(task, plant.gravity_torque(task.q_goal));
  // start: the arm held still at q0 by its gravity torque
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(2 * plant.nv());
  x0.head(plant.nv()) = task.q0;
  const std::vector<Eigen::VectorXd> u_init(static_cast<std::size_t>(task.horizon), plant.gravity_torque(task.q0));
  r.initial_q_error = (task.q0 - task.q_goal).norm();

  // one of the two, behind the same Linearize
  std::optional<DaemonLinearizer> daemon;
  std::optional<KernelLinearizer> kernel;
  Linearize linearize;
  const LinearizerStats* stats = nullptr;
  if (run.kernel) {
    kernel.emplace(run.format, reference);
    linearize = [&kernel](const Trajectory& t, Linearization& out) { return (*kernel)(t, out); };
    stats = &kernel->stats();
  } else {
    daemon.emplace(client, kModel, run.backend, run.precision, reference);
    linearize = [&daemon](const Trajectory& t, Linearization& out) { return (*daemon)(t, out); };
    stats = &daemon->stats();
  }
  const std::string label = run.kernel ? "kernel " + run.format.name : r.backend + " " + r.precision;
  auto progress = [&label](const IlqrIteration& it) {
    char gradients[64] = " (same linearization)";
    if (it.linearize_s > 0) std::snprintf(gradients, sizeof gradients, " gradients %.2f ms", it.linearize_s * 1e3);
    std::fprintf(stderr, "%s: iteration %3d cost %.6e alpha %-9.4g mu %.0e decrease %.3e (expected %.3e)%s\n",
                 label.c_str(), it.iteration, it.cost, it.alpha, it.mu, it.actual, it.expected, gradients);
  };
  const auto start = std::chrono::steady_clock::now();
  const IlqrResult result = run_ilqr(
      [&plant](const Eigen::VectorXd& x, const Eigen::VectorXd& u, Eigen::VectorXd& next) {
        return plant.step(x, u, next);
      },
      linearize, cost, x0, u_init, ilqr, progress);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const LinearizerStats& s = *stats;
  r.mode = s.backend_mode;
  const bool overflowed = result.failed && kernel && kernel->overflowed();
  if (result.failed && !overflowed) {
    r.outcome = RunRecord::Outcome::kFailed;
    r.reason = result.stop_reason;
    return r;
  }
  // an overflow ends the run where it is: its trajectory is the last accepted one, its iterations
  // those before the linearization that overflowed
  if (overflowed) r.outcome = RunRecord::Outcome::kOverflowed;
  r.reason = result.stop_reason;
  r.iterations = overflowed ? result.iterations - 1 : result.iterations;
  r.gradient_calls = s.calls;
  r.converged = result.converged;
  r.initial_cost = result.initial_cost;
  r.final_cost = result.final_cost;
  r.wall_s = elapsed - s.check_s;
  r.gradient_s = s.gradient_s;
  r.server_compute_s = s.server_compute_s;
  r.max_grad_error = s.max_grad_error;
  r.max_minv_error = s.max_minv_error;
  r.fallback_states = s.fallback_states;
  r.overflowed_states = s.overflowed_states;
  assess(task, description, result.trajectory, r);
  // a run stopped by an overflow did not finish, wherever it stopped
  if (overflowed) r.reached = false;
  std::fprintf(stderr, "%s: %s after %d iterations, cost %.6g -> %.6g, |q_T - q_goal| %.3e rad, |qd_T| %.3e rad/s: %s\n",
               label.c_str(), r.reason.c_str(), r.iterations, r.initial_cost, r.final_cost, r.q_error, r.qd_error,
               r.reached ? "goal reached" : "goal NOT reached");
  return r;
}

// "2026-12-02T11:30:00Z"
std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  f.flush();
  if (!f) std::cerr << "trajopt_bench: cannot write '" << path << "'\n";
  return static_cast<bool>(f);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Args args;
  std::string error = cli::Args::parse(kOptions, argc, argv, 1, args);
  if (error.empty() && args.has("help")) {
    std::cout << "usage: trajopt_bench [--server ADDR] [--runs LIST] [options]\n\n"
              << "iLQR on iiwa14 from rest at q0 to rest at q_goal; the rollouts in f64 in-process, the\n"
              << "linearization of each iteration from rbdgradd in one batched request, per backend and\n"
              << "precision, or from the FPGA kernel's arithmetic in-process per fixed-point format\n"
              << "(kernel:FORMAT; the daemon still gives the model). Progress on stderr, the Markdown table\n"
              << "on stdout.\n\noptions:\n"
              << cli::format_options(kOptions)
              << "\nexit status: 0 every run computed and lowered its cost and its distance to the goal, and\n"
              << "(unless --quick) every f64 and f32 run reached the goal: fixed point is reported, not\n"
              << "required, and a kernel run stopped by an overflow is reported as not reaching the goal;\n"
              << "1 otherwise; 2 usage error\n";
    return 0;
  }
  Options o;
  if (error.empty()) error = parse_options(args, o);
  if (!error.empty()) return usage_error(error);

  const Client client(o.server);
  ServerInfo info;
  ModelDescription description;
  if (RpcStatus st = client.server_info(info); !st) {
    std::cerr << "trajopt_bench: server info from " << o.server << ": " << st.to_string() << "\n";
    return 1;
  }
  if (RpcStatus st = client.get_model(kModel, description); !st) {
    std::cerr << "trajopt_bench: model " << kModel << " on " << o.server << ": " << st.to_string() << "\n";
    return 1;
  }
  // the plant is the daemon's model, with the daemon's gravity
  Model model;
  if (Status s = cli::load_model(kModel, description.gravity, model); !s) {
    std::cerr << "trajopt_bench: " << s.to_string() << "\n";
    return 1;
  }
  const ReachTask task = iiwa14_reach_task(o.quick);
  if (model.nv != task.q0.size() || description.nv != model.nv) {
    std::cerr << "trajopt_bench: the daemon's " << kModel << " has " << description.nv << " joints, the task "
              << task.q0.size() << "\n";
    return 1;
  }

  std::vector<RunRecord> not_ready;  // listed after the runs
  if (o.runs.empty()) {
    for (const BackendStatus& b : info.backends) {
      if (b.backend == Backend::kAuto) continue;
      if (!b.ready) {
        std::cerr << "trajopt_bench: skipping " << b.name << ": not available: " << b.reason << "\n";
        RunRecord r;
        r.backend = b.name;
        r.precision = "-";
        r.outcome = RunRecord::Outcome::kSkipped;
        r.reason = "not available: " + b.reason;
        not_ready.push_back(std::move(r));
        continue;
      }
      for (Precision p : b.precisions) o.runs.push_back(RunSpec{false, b.backend, p, {}});
    }
    // cpu, cuda, fpga; f64, f32, fixed (the enumerations' order), whatever order the daemon lists
    std::sort(o.runs.begin(), o.runs.end(), [](const RunSpec& a, const RunSpec& b) {
      return std::pair(a.backend, a.precision) < std::pair(b.backend, b.precision);
    });
    // then the kernel in every format, in-process: needs no backend of the daemon's
    for (const bench::FixedFormat& f : bench::fixed_formats()) o.runs.push_back(RunSpec{true, {}, {}, f});
  }
  if (o.runs.empty()) {
    std::cerr << "trajopt_bench: the daemon has no ready backend\n";
    return 1;
  }

  std::vector<RunRecord> records;
  bool ok = true;
  for (const RunSpec& run : o.runs) {
    std::string why = run.kernel ? "" : unavailable_reason(info, run.backend, run.precision);
    if (!why.empty()) {
      std::cerr << "trajopt_bench: skipping " << run.name() << ": " << why << "\n";
      RunRecord r;
      r.backend = backend_name(run.backend);
      r.precision = precision_name(run.precision);
      r.outcome = RunRecord::Outcome::kSkipped;
      r.reason = why;
      records.push_back(r);
      continue;
    }
    RunRecord r = run_one(client, model, description, task, o.ilqr, run);
    const bool fixed = run.kernel || run.precision == Precision::kFixed;
    if (r.outcome == RunRecord::Outcome::kFailed) {
      std::cerr << "trajopt_bench: " << run.name() << " failed: " << r.reason << "\n";
      ok = false;
    } else if (r.outcome == RunRecord::Outcome::kOverflowed) {
      // the format's result, reported as not reaching the goal; fixed point is not required to
      std::cerr << "trajopt_bench: " << run.name() << " stopped, goal not reached: " << r.reason << "\n";
    } else if (!(r.final_cost < r.initial_cost) || !(r.q_error < r.initial_q_error)) {
      std::cerr << "trajopt_bench: " << run.name() << " did not move toward the goal\n";
      ok = false;
    } else if (!o.quick && !fixed && !r.reached) {
      std::cerr << "trajopt_bench: " << run.name() << " did not reach the goal\n";
      ok = false;
    }
    records.push_back(std::move(r));
  }
  records.insert(records.end(), not_ready.begin(), not_ready.end());

  const std::string context = "rbdgradd " + info.version + ", " + utc_now() + ", " +
                              std::to_string(std::thread::hardware_concurrency()) + " cores" +
                              (o.quick ? ", --quick" : "") + ".";
  std::ostringstream md;
  write_markdown(md, task, context, records);
  std::cout << md.str() << std::flush;
  if (!o.markdown.empty() && !write_file(o.markdown, md.str())) ok = false;
  if (!o.csv.empty()) {
    std::ostringstream csv;
    write_csv(csv, records);
    if (!write_file(o.csv, csv.str())) ok = false;
  }
  return ok ? 0 : 1;
}
