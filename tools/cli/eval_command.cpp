// `rbdgrad eval`: options, the loop over the states of a file, the results file.
#include "eval_command.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "args.hpp"
#include "evaluator.hpp"
#include "model_source.hpp"
#include "result_header.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {
    {"model", "NAME|PATH", "embedded robot (hyq, iiwa14, panda, talos_reduced) or URDF file; default iiwa14"},
    {"in", "STATES.jsonl", "input states ('-' for stdin); required"},
    {"out", "RESULTS.jsonl", "output results ('-' for stdout); required"},
    {"precision", "f64|f32|fixed", "scalar type of the computation; default f64 (fixed = Q16.16)"},
    {"outputs", "LIST", "comma-separated subset of qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd; default all"},
    {"gravity", "GX,GY,GZ", "world-frame gravity in m/s^2; default 0,0,-9.81"},
    {"help", "", "show this help"},
};

// Errors beyond this many are counted, not printed, on stderr (all are in the output file).
constexpr std::size_t kMaxPrintedErrors = 20;

struct EvalOptions {
  std::string model = "iiwa14";
  std::string in, out;
  std::string precision = "f64";
  OutputSet outputs{};
  std::optional<Eigen::Vector3d> gravity;
};

void print_help(std::ostream& os) {
  os << "usage: rbdgrad eval --in STATES.jsonl --out RESULTS.jsonl [options]\n\n"
     << kEvalSummary << ".\n"
     << "Each input line after the header holds q, qd and tau (then qdd = FD(q, qd, tau)) or qdd.\n"
     << "Each output line holds index, kind and the selected outputs (matrices nv x nv, row-major),\n"
     << "or {\"index\":k,\"error\":\"...\"} for a state that could not be evaluated.\n\n"
     << "options:\n"
     << format_options(kOptions)
     << "\nexit status: 0 all states evaluated, 1 a state failed or a file error, 2 usage error\n";
}

int usage_error(const std::string& message) {
  std::cerr << "rbdgrad eval: " << message << "\n"
            << "usage: rbdgrad eval --in STATES.jsonl --out RESULTS.jsonl [options] (see rbdgrad eval --help)\n";
  return 2;
}

// Fills `o` from the arguments; returns "" or the usage problem.
std::string parse_options(const Args& args, EvalOptions& o) {
  o.model = args.value_or("model", o.model);
  o.in = args.value_or("in", "");
  o.out = args.value_or("out", "");
  if (o.in.empty()) return "--in is required";
  if (o.out.empty()) return "--out is required";
  o.precision = args.value_or("precision", o.precision);
  if (o.precision != "f64" && o.precision != "f32" && o.precision != "fixed")
    return "unknown precision '" + o.precision + "' (f64, f32 or fixed)";
  o.outputs.fill(true);
  if (const std::string* list = args.value("outputs")) {
    std::string error;
    const std::optional<OutputSet> set = parse_outputs(*list, error);
    if (!set) return error;
    o.outputs = *set;
  }
  if (const std::string* g = args.value("gravity")) {
    std::vector<double> v;
    if (std::string error = parse_numbers(*g, 3, v); !error.empty()) return "--gravity: " + error;
    o.gravity = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return "";
}

// The result file's first line: what was computed, with which model, in which order.
std::string header_json(const Model& model, const EvalOptions& o, std::size_t n_states) {
  ResultHeader h;
  h.robot = model.name;
  h.source = model.source;
  h.nv = model.nv;
  for (const JointInfo& j : model.joints) h.joint_names.push_back(j.name);
  h.gravity = {model.gravity.x(), model.gravity.y(), model.gravity.z()};
  h.precision = o.precision;
  for (int k = 0; k < kNumOutputs; ++k)
    if (o.outputs[static_cast<std::size_t>(k)]) h.outputs.emplace_back(kOutputNames[static_cast<std::size_t>(k)]);
  h.input = o.in;
  h.n_states = n_states;
  h.generator = std::string("rbdgrad eval ") + RBDGRAD_VERSION;
  return dump_header(result_header_json(h));
}

// Mismatches between the input's header and the model do not stop the run (each state is checked),
// but they usually mean the wrong --model or --gravity: say so once.
void warn_about_header(const io::StateFileHeader& h, const Model& model) {
  if (h.nv >= 0 && h.nv != model.nv)
    std::cerr << "rbdgrad eval: warning: the input header has nv " << h.nv << " (" << h.robot << ") but model '"
              << model.name << "' has nv " << model.nv << "\n";
  if (!h.joint_names.empty() && h.joint_names.size() == model.joints.size()) {
    for (std::size_t i = 0; i < h.joint_names.size(); ++i) {
      if (h.joint_names[i] != model.joints[i].name) {
        std::cerr << "rbdgrad eval: warning: joint " << i << " is '" << h.joint_names[i] << "' in the input but '"
                  << model.joints[i].name << "' in the model: values are read in the model's joint order\n";
        break;
      }
    }
  }
  if (auto it = h.fields.find("gravity"); it != h.fields.end() && it->second.size() == 3) {
    const Eigen::Vector3d g(it->second[0], it->second[1], it->second[2]);
    if ((g - model.gravity).norm() > 1e-12 * (1 + g.norm()))
      std::cerr << "rbdgrad eval: warning: the input header has gravity [" << g.transpose()
                << "] but the model uses [" << model.gravity.transpose() << "] (see --gravity)\n";
  }
}

struct RunCounts {
  std::size_t evaluated = 0, failed = 0;
};

// The loop over states in scalar S: a bad state gets an error object and the others go on.
template <class S>
RunCounts evaluate_states(const Model& model, const EvalOptions& o, const io::StateFile& file,
                          io::ResultWriter& writer) {
  Evaluator<S> evaluator(model, o.outputs);
  RunCounts counts;
  auto fail = [&](long index, const std::string& message) {
    writer.write_error(index, message);
    if (counts.failed++ < kMaxPrintedErrors) std::cerr << "rbdgrad eval: " << message << "\n";
  };
  for (const io::StateRecord& s : file.states) {
    // the algorithms trust their inputs: sizes and finiteness are checked here first
    if (std::string problem = io::check_dynamics_input(s, model.nv); !problem.empty()) {
      fail(s.index, problem);
      continue;
    }
    if (Status st = evaluator.evaluate(s); !st) {
      fail(s.index, "state " + std::to_string(s.index) + ": " + st.to_string());
      continue;
    }
    writer.write_state(s.index, s.kind, evaluator.arrays());
    ++counts.evaluated;
  }
  return counts;
}

}  // namespace

int run_eval_command(int argc, const char* const* argv, int first) {
  Args args;
  if (std::string error = Args::parse(kOptions, argc, argv, first, args); !error.empty()) return usage_error(error);
  if (args.has("help")) {
    print_help(std::cout);
    return 0;
  }
  EvalOptions o;
  if (std::string error = parse_options(args, o); !error.empty()) return usage_error(error);

  Model model;
  if (Status st = load_model(o.model, o.gravity, model); !st) {
    std::cerr << "rbdgrad eval: " << st.to_string() << "\n";
    return 1;
  }
  io::StateFile file;
  std::string error;
  const bool read_ok =
      o.in == "-" ? io::parse_state_file(std::cin, "<stdin>", file, error) : io::read_state_file(o.in, file, error);
  if (!read_ok) {
    std::cerr << "rbdgrad eval: " << error << "\n";
    return 1;
  }
  warn_about_header(file.header, model);

  std::ofstream out_file;
  if (o.out != "-") {
    out_file.open(o.out, std::ios::binary | std::ios::trunc);
    if (!out_file) {
      std::cerr << "rbdgrad eval: cannot write '" << o.out << "'\n";
      return 1;
    }
  }
  std::ostream& out = o.out == "-" ? std::cout : out_file;
  io::ResultWriter writer(out);
  writer.write_header(header_json(model, o, file.states.size()));
  RunCounts counts;
  if (o.precision == "f64") counts = evaluate_states<double>(model, o, file, writer);
  else if (o.precision == "f32") counts = evaluate_states<float>(model, o, file, writer);
  else counts = evaluate_states<Q16_16>(model, o, file, writer);
  out.flush();
  if (!writer.ok() || !out) {
    std::cerr << "rbdgrad eval: writing '" << o.out << "' failed\n";
    return 1;
  }
  if (writer.nonfinite_count() > 0) {
    // the evaluator checks results, so this is a bug; still never pass it silently
    std::cerr << "rbdgrad eval: internal: " << writer.nonfinite_count() << " non-finite values written as null\n";
    return 1;
  }
  if (counts.failed > kMaxPrintedErrors)
    std::cerr << "rbdgrad eval: ... and " << counts.failed - kMaxPrintedErrors << " more errors\n";
  std::cerr << "rbdgrad eval: " << counts.evaluated << " of " << file.states.size() << " states evaluated";
  if (counts.failed) std::cerr << ", " << counts.failed << " failed";
  std::cerr << " (" << model.name << ", " << o.precision << ", results in " << (o.out == "-" ? "stdout" : o.out)
            << ")\n";
  return counts.failed ? 1 : 0;
}

}  // namespace rbdgrad::cli
