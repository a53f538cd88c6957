// accuracy_bench: run time against error for every shipped robot, backend and precision (issue 7).
// For each robot: the Pinocchio reference states (tests/data/reference/<robot>.jsonl) and seeded
// random states; for each backend plugin that loads here (cpu; cuda where a GPU is present; fpga
// as the kernel's C simulation) and each precision it has, the error of dqdd/dq and dqdd/dqd
// against Pinocchio and against the CPU's f64 result, and the time per state at each N; then the
// FPGA kernel's arithmetic in other fixed-point formats (fixed_format_kernel.hpp). Writes CSV and
// Markdown; bench/accuracy/run_accuracy.sh turns them into docs/benchmarks/accuracy.md with plots.
// Exits 1 when any backend passed on a NaN or Inf without flagging the state, or when the FPGA
// plugin's C simulation and the kernel run here disagree in Q16.16.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "accuracy_report.hpp"
#include "accuracy_states.hpp"
#include "args.hpp"
#include "error_summary.hpp"
#include "fixed_format_kernel.hpp"
#include "plugin_runner.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using namespace rbdgrad;
using namespace rbdgrad::bench;

#ifndef RBDGRAD_CUDA_PLUGIN_PATH
#define RBDGRAD_CUDA_PLUGIN_PATH ""
#endif

constexpr cli::OptionSpec kOptions[] = {
    {"robots", "LIST", "embedded robots; default iiwa14,panda,hyq,talos_reduced"},
    {"sizes", "LIST", "batch sizes timed; default 1,16,64,128,1024 (add 4096,16384,65536 on a GPU)"},
    {"backends", "LIST", "subset of cpu,cuda,fpga,kernel (kernel: the FPGA kernel's other formats); default all"},
    {"cpu-plugin", "PATH", "the CPU plugin; default the build's"},
    {"cuda-plugin", "PATH", "the CUDA plugin; default the build's (skipped when it reports no GPU)"},
    {"fpga-plugin", "PATH", "the FPGA plugin, run as its kernel's C simulation; default the build's"},
    {"reference-dir", "DIR", "the Pinocchio reference files <robot>.jsonl; default the source tree's tests/data/reference"},
    {"random-states", "K", "random states compared with the CPU's f64 result; default 256"},
    {"min-time", "SEC", "each timing repeats calls for at least this long; default 0.2"},
    {"csv", "PATH", "write the rows as CSV (one line per N)"},
    {"markdown", "PATH", "write a Markdown table per robot"},
    {"quick", "", "iiwa14 only, N = 1 and 16, 32 random states, short timings: a smoke test"},
    {"help", "", "show this help"},
};

struct Options {
  std::vector<std::string> robots = {"iiwa14", "panda", "hyq", "talos_reduced"};
  std::vector<std::uint64_t> sizes = {1, 16, 64, 128, 1024};
  std::vector<std::string> backends = {"cpu", "cuda", "fpga", "kernel"};
  std::string cpu_plugin = RBDGRAD_CPU_PLUGIN_PATH, cuda_plugin = RBDGRAD_CUDA_PLUGIN_PATH,
              fpga_plugin = RBDGRAD_FPGA_PLUGIN_PATH, reference_dir = RBDGRAD_REFERENCE_DIR;
  std::size_t random_states = 256;
  double min_time = 0.2;
  std::string csv, markdown;
};

bool wants(const Options& o, const std::string& backend) {
  for (const std::string& b : o.backends)
    if (b == backend) return true;
  return false;
}

std::string parse(int argc, char** argv, Options& o) {
  cli::Args args;
  if (std::string e = cli::Args::parse(kOptions, argc, argv, 1, args); !e.empty()) return e;
  if (args.has("help")) {
    std::cout << "usage: accuracy_bench [options]\n\nRun time against error of every backend and precision.\n\noptions:\n"
              << cli::format_options(kOptions);
    return "help";
  }
  if (args.has("quick")) {
    o.robots = {"iiwa14"};
    o.sizes = {1, 16};
    o.random_states = 32;
    o.min_time = 0.02;
  }
  if (const std::string* v = args.value("robots")) o.robots = cli::split_list(*v);
  if (const std::string* v = args.value("backends")) o.backends = cli::split_list(*v);
  if (const std::string* v = args.value("sizes")) {
    o.sizes.clear();
    for (const std::string& s : cli::split_list(*v)) {
      char* end = nullptr;
      const unsigned long long n = std::strtoull(s.c_str(), &end, 10);
      if (*end != '\0' || n == 0) return "--sizes: '" + s + "' is not a positive number";
      o.sizes.push_back(n);
    }
  }
  if (const std::string* v = args.value("random-states")) o.random_states = std::strtoull(v->c_str(), nullptr, 10);
  if (const std::string* v = args.value("min-time")) o.min_time = std::strtod(v->c_str(), nullptr);
  o.cpu_plugin = args.value_or("cpu-plugin", o.cpu_plugin);
  o.cuda_plugin = args.value_or("cuda-plugin", o.cuda_plugin);
  o.fpga_plugin = args.value_or("fpga-plugin", o.fpga_plugin);
  o.reference_dir = args.value_or("reference-dir", o.reference_dir);
  o.csv = args.value_or("csv", "");
  o.markdown = args.value_or("markdown", "");
  if (o.random_states == 0) return "--random-states must be positive";
  return "";
}

const char* precision_label(std::uint32_t p) {
  return p == RBDGRAD_PRECISION_F64 ? "f64" : p == RBDGRAD_PRECISION_F32 ? "f32" : "Q16.16";
}

// Everything one robot needs: its model, the states, and the f64 truth on the random states.
struct RobotCase {
  Model model;
  StateSet reference, random, compared;  // compared: the first random states, for the f64 errors
  Gradients f64;                         // the CPU plugin's f64 result on `compared`
};

class Bench {
 public:
  explicit Bench(Options o) : o_(std::move(o)) {}

  int run() {
    for (std::size_t r = 0; r < o_.robots.size(); ++r) {
      const std::string& robot = o_.robots[r];
      progress("[robot " + std::to_string(r + 1) + "/" + std::to_string(o_.robots.size()) + "] " + robot);
      if (!run_robot(robot)) return 2;
    }
    if (!o_.csv.empty()) {
      std::ofstream f(o_.csv);
      write_csv(f, rows_);
      if (!f) return fail("cannot write " + o_.csv);
    }
    if (!o_.markdown.empty()) {
      std::ofstream f(o_.markdown);
      write_markdown(f, rows_, o_.sizes);
      if (!f) return fail("cannot write " + o_.markdown);
    }
    std::size_t silent = 0;
    for (const AccuracyRow& row : rows_) silent += row.vs_reference.unflagged_nonfinite + row.vs_f64.unflagged_nonfinite;
    if (silent > 0) problems_.push_back(std::to_string(silent) + " states with NaN or Inf were not flagged");
    for (const std::string& p : problems_) std::cerr << "accuracy_bench: FAILED: " << p << "\n";
    return problems_.empty() ? 0 : 1;
  }

 private:
  static void progress(const std::string& line) { std::cerr << "accuracy_bench: " << line << std::endl; }
  static int fail(const std::string& message) {
    std::cerr << "accuracy_bench: " << message << "\n";
    return 2;
  }

  bool run_robot(const std::string& robot) {
    RobotCase c;
    if (Status s = load_urdf_string(std::string(embedded_robot_urdf(robot)), robot + ".urdf", c.model); !s) {
      fail(robot + ": " + s.to_string());
      return false;
    }
    if (Status s = reference_states(o_.reference_dir + "/" + robot + ".jsonl", c.model, c.reference); !s) {
      fail(s.to_string());
      return false;
    }
    std::uint64_t largest = o_.random_states;
    for (std::uint64_t n : o_.sizes) largest = std::max(largest, n);
    c.random = random_states(c.model, largest, 1);
    c.compared = first_states(c.random, o_.random_states);

    std::unique_ptr<PluginRunner> cpu;
    if (Status s = PluginRunner::open(o_.cpu_plugin, c.model, {}, cpu); !s) {
      fail("the CPU plugin is needed for the f64 result: " + s.to_string());
      return false;
    }
    if (Status s = cpu->compute(c.compared, RBDGRAD_PRECISION_F64, c.f64); !s) {
      fail(robot + ": cpu f64: " + s.to_string());
      return false;
    }
    if (wants(o_, "cpu")) run_plugin(c, *cpu);
    if (wants(o_, "cuda")) open_and_run(c, "cuda", o_.cuda_plugin, {});
    Gradients fpga_q16;  // the plugin's C simulation on the reference states, for the kernel check
    std::vector<std::pair<std::uint64_t, double>> cycle_model;  // the FPGA plugin's, per state
    if (wants(o_, "fpga") || wants(o_, "kernel")) {
      std::unique_ptr<PluginRunner> fpga;
      if (Status s = PluginRunner::open(o_.fpga_plugin, c.model, {{"emulation", "csim"}}, fpga); !s) {
        progress(robot + ": fpga: skipped: " + s.to_string());
      } else {
        if (wants(o_, "fpga")) run_plugin(c, *fpga);
        if (!fpga->compute(c.reference, RBDGRAD_PRECISION_FIXED_Q16_16, fpga_q16)) fpga_q16 = Gradients{};
        for (std::uint64_t n : o_.sizes) {
          double us = 0;
          if (fpga->model_us(RBDGRAD_PRECISION_FIXED_Q16_16, n, us)) cycle_model.emplace_back(n, us / static_cast<double>(n));
        }
      }
    }
    if (wants(o_, "kernel")) run_kernel_formats(c, fpga_q16, cycle_model.empty() ? nullptr : &cycle_model);
    return true;
  }

  void open_and_run(const RobotCase& c, const std::string& name, const std::string& path,
                    const std::map<std::string, std::string>& options) {
    if (path.empty()) {
      progress(c.model.name + ": " + name + ": skipped: not built here");
      return;
    }
    std::unique_ptr<PluginRunner> runner;
    if (Status s = PluginRunner::open(path, c.model, options, runner); !s) {
      progress(c.model.name + ": " + name + ": skipped: " + s.to_string());
      return;
    }
    run_plugin(c, *runner);
  }

  void run_plugin(const RobotCase& c, PluginRunner& plugin) {
    for (std::uint32_t precision : {RBDGRAD_PRECISION_F64, RBDGRAD_PRECISION_F32, RBDGRAD_PRECISION_FIXED_Q16_16}) {
      if ((plugin.precisions() & precision) == 0) continue;
      AccuracyRow row;
      row.robot = c.model.name;
      row.nv = c.model.nv;
      row.backend = plugin.name();
      row.mode = plugin.mode();
      row.precision = precision_label(precision);
      const std::string what = row.robot + ": " + row.backend + " " + row.precision;
      Gradients got;
      if (Status s = plugin.compute(c.reference, precision, got); !s) {
        problems_.push_back(what + ": " + s.to_string());
        continue;
      }
      row.vs_reference = compare_gradients(got, c.reference.dqdd_dq, c.reference.dqdd_dqd, c.model.nv);
      row.has_vs_f64 = !(row.backend == "cpu" && precision == RBDGRAD_PRECISION_F64);
      if (row.has_vs_f64) {
        if (Status s = plugin.compute(c.compared, precision, got); !s) {
          problems_.push_back(what + ": " + s.to_string());
          continue;
        }
        row.vs_f64 = compare_gradients(got, c.f64.dqdd_dq, c.f64.dqdd_dqd, c.model.nv);
      }
      // a backend with a latency model of its own (the FPGA's cycle count) is not timed: its C
      // simulation's time says nothing about a card
      row.timing = "measured";
      for (std::uint64_t n : o_.sizes) {
        double us = 0;
        if (plugin.model_us(precision, n, us)) {
          row.timing = "cycle model";
        } else if (Status s = plugin.time(first_states(c.random, n), precision, o_.min_time, us); !s) {
          problems_.push_back(what + ": N = " + std::to_string(n) + ": " + s.to_string());
          break;
        }
        row.us_per_state.emplace_back(n, us / static_cast<double>(n));
      }
      progress(what + ": median error vs Pinocchio " + std::to_string(row.vs_reference.dqdd_dq.median) + " (dq), " +
               std::to_string(row.vs_reference.dqdd_dqd.median) + " (dqd)");
      rows_.push_back(std::move(row));
    }
  }

  void run_kernel_formats(const RobotCase& c, const Gradients& plugin_q16,
                          const std::vector<std::pair<std::uint64_t, double>>* cycle_model) {
    for (const FixedFormat& format : fixed_formats()) {
      AccuracyRow row;
      row.robot = c.model.name;
      row.nv = c.model.nv;
      row.backend = "fpga kernel";
      row.mode = "host";
      row.precision = format.name;
      const std::string what = row.robot + ": fpga kernel " + format.name;
      Gradients got;
      if (Status s = run_fixed_format(format, c.model, c.reference, got); !s) {
        progress(what + ": skipped: " + s.to_string());
        continue;
      }
      // the bitstream's format must give exactly what the plugin's C simulation gives
      if (format.name == "Q16.16" && !plugin_q16.state_status.empty() &&
          (got.dqdd_dq != plugin_q16.dqdd_dq || got.dqdd_dqd != plugin_q16.dqdd_dqd ||
           got.state_status.size() != plugin_q16.state_status.size()))
        problems_.push_back(what + ": differs from the FPGA plugin's C simulation on the reference states");
      row.vs_reference = compare_gradients(got, c.reference.dqdd_dq, c.reference.dqdd_dqd, c.model.nv);
      if (Status s = run_fixed_format(format, c.model, c.compared, got); !s) continue;
      row.vs_f64 = compare_gradients(got, c.f64.dqdd_dq, c.f64.dqdd_dqd, c.model.nv);
      // the same pipeline in another word width: the cycle count of Q16.16's (an assumption: a
      // wider word costs DSP slices and routing, which the cycle model does not see)
      if (cycle_model != nullptr) {
        row.timing = "cycle model (Q16.16's)";
        row.us_per_state = *cycle_model;
      } else {
        row.timing = "not timed";
      }
      progress(what + ": median error vs Pinocchio " + std::to_string(row.vs_reference.dqdd_dq.median) + " (dq), " +
               std::to_string(row.vs_reference.flagged) + " flagged");
      rows_.push_back(std::move(row));
    }
  }

  Options o_;
  std::vector<AccuracyRow> rows_;
  std::vector<std::string> problems_;
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (std::string e = parse(argc, argv, o); !e.empty()) {
    if (e == "help") return 0;
    std::cerr << "accuracy_bench: " << e << "\n";
    return 2;
  }
  return Bench(std::move(o)).run();
}
