// `rbdgrad compute`: dynamics and gradients computed by the daemon, for random states or a state
// file, with a summary of where and how fast; the results file is the one `rbdgrad eval` writes.
#include "compute_command.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>

#include "compute_batches.hpp"
#include "compute_states.hpp"
#include "evaluator.hpp"
#include "result_header.hpp"
#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {
    kServerOption,
    kTlsCaOption,
    kTlsCertOption,
    kTlsKeyOption,
    kTokenFileOption,
    {"model", "NAME", "a model the daemon serves (rbdgrad models); default iiwa14"},
    {"scene", "NAME", "a scene the daemon serves (rbdgrad scenes) instead of a model: its joints, its outputs by default"},
    {"n", "N", "compute N random states: q within the joint limits, qd in [-1,1], tau within half the effort limit"},
    {"seed", "S", "seed of the random states; default 1"},
    {"in", "STATES.jsonl", "compute the states of a file instead ('-' for stdin), read as rbdgrad eval reads it"},
    {"out", "RESULTS.jsonl", "write the results as rbdgrad eval does ('-' for stdout)"},
    {"precision", "auto|f64|f32|fixed", "scalar type of the computation; default auto (the daemon's choice)"},
    {"backend", "auto|cpu|cuda|fpga", "backend hint; default auto"},
    {"input", "tau|qdd", "the input: --n draws it; --in reads that field (default: tau when a state has it, else qdd)"},
    {"outputs", "LIST", "comma-separated subset of qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd; default all"},
    {"output-type", "f64|f32", "encoding of the outputs on the wire; default f64"},
    kTimeoutOption,
    {"help", "", "show this help"},
};

// the service's outputs (cli::Output is eval's enumeration of the file's outputs)
using ServiceOutput = rbdgrad::Output;

// eval's output order (kOutputNames) -> the service's outputs
constexpr ServiceOutput kServiceOutput[kNumOutputs] = {ServiceOutput::kQdd,     ServiceOutput::kM,   ServiceOutput::kMinv,   ServiceOutput::kDqddDq,
                                                ServiceOutput::kDqddDqd, ServiceOutput::kTau, ServiceOutput::kDtauDq, ServiceOutput::kDtauDqd};

struct ComputeOptions {
  std::string model = "iiwa14";
  std::string scene;
  std::optional<std::uint32_t> n;
  std::uint64_t seed = 1;
  std::string in, out;
  std::optional<ComputeInput> input;
  OutputSet outputs{};
  BatchPlan plan;
};

int usage_error(const std::string& message) {
  std::cerr << "rbdgrad compute: " << message << "\n"
            << "usage: rbdgrad compute [--server ADDR] (--n N | --in STATES.jsonl) [options] (see rbdgrad compute --help)\n";
  return 2;
}

template <class T>
bool parse_integer(const std::string& text, T& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

// Fills `o` from the arguments; returns "" or the usage problem.
std::string parse_options(const Args& args, ComputeOptions& o) {
  o.model = args.value_or("model", o.model);
  o.scene = args.value_or("scene", "");
  if (!o.scene.empty() && args.has("model")) return "give --model or --scene, not both";
  o.in = args.value_or("in", "");
  o.out = args.value_or("out", "");
  if (const std::string* n = args.value("n")) {
    std::uint32_t v = 0;
    if (!parse_integer(*n, v) || v == 0) return "--n: '" + *n + "' is not a positive number of states";
    o.n = v;
  }
  if (o.n.has_value() == !o.in.empty()) return o.n ? "give --n or --in, not both" : "--n or --in is required";
  if (const std::string* s = args.value("seed"); s && !parse_integer(*s, o.seed))
    return "--seed: '" + *s + "' is not a non-negative integer";
  if (args.has("seed") && !o.n) return "--seed goes with --n";
  if (const std::string* p = args.value("precision"); p && !parse_precision(*p, o.plan.precision))
    return "unknown precision '" + *p + "' (auto, f64, f32 or fixed)";
  if (const std::string* b = args.value("backend"); b && !parse_backend(*b, o.plan.backend))
    return "unknown backend '" + *b + "' (auto, cpu, cuda or fpga)";
  if (const std::string* t = args.value("output-type"); t && !parse_scalar_type(*t, o.plan.output_type))
    return "unknown output type '" + *t + "' (f64 or f32)";
  if (const std::string* i = args.value("input")) {
    ComputeInput input{};
    if (!parse_input(*i, input)) return "unknown input '" + *i + "' (tau or qdd)";
    o.input = input;
  }
  o.outputs.fill(true);
  if (const std::string* list = args.value("outputs")) {
    std::string error;
    const std::optional<OutputSet> set = parse_outputs(*list, error);
    if (!set) return error;
    o.outputs = *set;
  }
  for (int k = 0; k < kNumOutputs; ++k)
    if (o.outputs[static_cast<std::size_t>(k)]) o.plan.outputs |= mask(kServiceOutput[k]);
  o.plan.model = o.scene.empty() ? o.model : "";
  o.plan.scene = o.scene;
  return "";
}

// The outputs of one state as float64 arrays for the result writer: views for f64 outputs, copies
// for f32 ones.
class StateArrays {
 public:
  explicit StateArrays(const OutputSet& outputs) : outputs_(outputs) {}

  const std::vector<io::OutputArray>& of(const ComputeResult& r, std::uint32_t k) {
    arrays_.clear();
    for (int i = 0; i < kNumOutputs; ++i) {
      if (!outputs_[static_cast<std::size_t>(i)]) continue;
      const ServiceOutput o = kServiceOutput[i];
      const std::size_t size = static_cast<std::size_t>(is_vector_output(o) ? r.nv() : r.nv() * r.nv());
      const double* data = nullptr;
      if (r.output_type() == ScalarType::kF64) {
        data = r.block(o).data() + k * size;
      } else {
        std::vector<double>& copy = copies_[static_cast<std::size_t>(i)];
        const std::span<const float> block = r.block_f32(o).subspan(k * size, size);
        copy.assign(block.begin(), block.end());
        data = copy.data();
      }
      arrays_.push_back({kOutputNames[static_cast<std::size_t>(i)], data, size});
    }
    return arrays_;
  }

 private:
  OutputSet outputs_;
  std::array<std::vector<double>, kNumOutputs> copies_;
  std::vector<io::OutputArray> arrays_;
};

std::size_t count_nonfinite(const ComputedStates& computed) {
  std::size_t bad = 0;
  auto count = [&bad](auto block) {
    for (auto v : block) bad += !std::isfinite(v);
  };
  for (const ComputeResult& r : computed.results) {
    for (ServiceOutput o : kEveryOutput) {
      if (!r.has(o)) continue;
      if (r.output_type() == ScalarType::kF64) count(r.block(o));
      else count(r.block_f32(o));
    }
  }
  return bad;
}

// Writes the results file; returns "" or the problem.
std::string write_results(const ComputeOptions& o, const std::string& server, const ModelDescription& model,
                          const std::string& source, const std::vector<InputState>& states,
                          const ComputedStates& computed) {
  std::ofstream file;
  if (o.out != "-") {
    file.open(o.out, std::ios::binary | std::ios::trunc);
    if (!file) return "cannot write '" + o.out + "'";
  }
  std::ostream& out = o.out == "-" ? std::cout : file;
  ResultHeader h;
  h.robot = model.name;
  h.source = source;
  h.nv = model.nv;
  for (const JointDescription& j : model.joints) h.joint_names.push_back(j.name);
  h.gravity = {model.gravity.x(), model.gravity.y(), model.gravity.z()};
  // the precision the server used (the same for every request)
  h.precision = computed.results.empty() ? precision_name(o.plan.precision)
                                         : precision_name(computed.results.front().precision());
  for (int k = 0; k < kNumOutputs; ++k)
    if (o.outputs[static_cast<std::size_t>(k)]) h.outputs.emplace_back(kOutputNames[static_cast<std::size_t>(k)]);
  h.input = o.in.empty() ? "random (--n " + std::to_string(*o.n) + " --seed " + std::to_string(o.seed) + ")" : o.in;
  h.n_states = states.size();
  h.generator = std::string("rbdgrad compute ") + RBDGRAD_VERSION;
  nlohmann::ordered_json header = result_header_json(h);
  // where it was computed (compare_results.py ignores these)
  header["server"] = server;
  if (!computed.results.empty()) {
    const ComputeResult& r = computed.results.front();
    header["backend"] = backend_name(r.backend());
    if (!r.backend_mode().empty()) header["backend_mode"] = r.backend_mode();
  }
  io::ResultWriter writer(out);
  writer.write_header(dump_header(header));
  StateArrays arrays(o.outputs);
  for (std::size_t s = 0; s < states.size(); ++s) {
    const ComputedStates::Slot& slot = computed.slots[s];
    if (slot.result < 0) writer.write_error(states[s].index, slot.error);
    else writer.write_state(states[s].index, states[s].kind,
                            arrays.of(computed.results[static_cast<std::size_t>(slot.result)], slot.k));
  }
  out.flush();
  if (!writer.ok() || !out) return "writing '" + o.out + "' failed";
  return "";
}

}  // namespace

int run_compute_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad compute [--server ADDR] (--n N | --in STATES.jsonl) [options]\n\n"
              << kComputeSummary << ".\n"
              << "Prints the model, the number of states, the backend and precision used, the server's\n"
              << "timings (queue, compute, total) and the client's round trip, and checks the outputs.\n\n"
              << "options:\n" << format_options(kOptions)
              << "\nexit status: 0 every state computed, 1 a call or a state failed, 2 usage error\n";
    return 0;
  }
  ComputeOptions o;
  std::unique_ptr<Client> client;
  if (error.empty()) error = parse_options(args, o);
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) return usage_error(error);
  // the summary goes where the results do not
  std::ostream& report = o.out == "-" ? std::cerr : std::cout;

  ModelDescription model;
  if (o.scene.empty()) {
    if (RpcStatus st = client->get_model(o.model, model); !st) return report_rpc_failure("compute", *client, st);
  } else {
    // the scene's joints are the states' and results'; its outputs unless --outputs says otherwise
    SceneDescription scene;
    if (RpcStatus st = client->get_scene(o.scene, scene); !st) return report_rpc_failure("compute", *client, st);
    if (RpcStatus st = client->get_model(scene.model, model); !st) return report_rpc_failure("compute", *client, st);
    model.name = scene.name;
    model.nv = scene.nv;
    model.joints = scene.joints;
    if (!scene.gravity) model.gravity.setZero();
    if (!args.has("outputs")) {
      for (int k = 0; k < kNumOutputs; ++k)
        o.outputs[static_cast<std::size_t>(k)] = (scene.outputs & mask(kServiceOutput[k])) != 0;
      o.plan.outputs = scene.outputs;
    }
  }
  ServerInfo info;
  if (RpcStatus st = client->server_info(info); !st) return report_rpc_failure("compute", *client, st);
  o.plan.nv = model.nv;
  o.plan.max_states_per_request = info.max_states_per_request;
  o.plan.max_message_bytes = info.max_message_bytes;

  std::vector<InputState> states;
  if (o.n) {
    states = random_states(model, *o.n, o.seed, o.input.value_or(ComputeInput::kTau));
  } else {
    io::StateFile file;
    const bool read_ok = o.in == "-" ? io::parse_state_file(std::cin, "<stdin>", file, error)
                                     : io::read_state_file(o.in, file, error);
    if (!read_ok) {
      std::cerr << "rbdgrad compute: " << error << "\n";
      return 1;
    }
    if (file.header.nv >= 0 && file.header.nv != model.nv)
      std::cerr << "rbdgrad compute: warning: the input header has nv " << file.header.nv << " but model '"
                << model.name << "' has nv " << model.nv << "\n";
    states = file_states(file, model.nv, o.input ? &*o.input : nullptr);
  }

  ComputedStates computed;
  if (RpcStatus st = compute_in_batches(*client, o.plan, states, computed); !st)
    return report_rpc_failure("compute", *client, st);

  std::size_t failed = 0;
  for (std::size_t s = 0; s < states.size(); ++s) {
    if (computed.slots[s].result >= 0) continue;
    if (failed++ < 20) std::cerr << "rbdgrad compute: " << computed.slots[s].error << "\n";
  }
  if (failed > 20) std::cerr << "rbdgrad compute: ... and " << failed - 20 << " more errors\n";
  if (!o.out.empty()) {
    std::string source;
    std::vector<ServedModel> served;
    if (client->list_models(served))
      for (const ServedModel& m : served)
        if (m.name == model.name) source = m.source;
    if (std::string problem = write_results(o, client->address(), model, source, states, computed); !problem.empty()) {
      std::cerr << "rbdgrad compute: " << problem << "\n";
      return 1;
    }
  }

  // the summary: what ran where, how fast, and whether the numbers are sane
  const std::size_t nonfinite = count_nonfinite(computed);
  const std::size_t requests_ok = computed.results.size();
  report << (o.scene.empty() ? "model " : "scene ") << model.name << " (nv " << model.nv << ") on " << client->address()
         << ": "
         << states.size() - failed << " of " << states.size() << " states computed in " << computed.requests
         << (computed.requests == 1 ? " request" : " requests") << "\n";
  if (requests_ok > 0) {
    const ComputeResult& r = computed.results.front();
    auto per_request = [&](double total) { return total / static_cast<double>(requests_ok); };
    report << "backend " << backend_name(r.backend());
    if (!r.backend_mode().empty()) report << " (" << r.backend_mode() << ")";
    report << ", precision " << precision_name(r.precision()) << ", outputs sent as " << scalar_type_name(r.output_type())
           << "\n";
    std::size_t fallbacks = 0;
    const ComputeResult* fell_back = nullptr;
    for (const ComputeResult& each : computed.results) {
      fallbacks += each.fallback_states().size();
      if (!each.fallback_states().empty() && fell_back == nullptr) fell_back = &each;
    }
    if (fell_back != nullptr)
      report << fallbacks << (fallbacks == 1 ? " state" : " states") << " left the fixed-point range and "
             << (fallbacks == 1 ? "was" : "were") << " computed again on " << backend_name(fell_back->fallback_backend())
             << " in " << precision_name(fell_back->fallback_precision()) << "\n";
    for (const ComputeResult& each : computed.results)
      for (const std::string& f : each.failovers()) report << "failover: " << f << "\n";
    for (const ComputeResult& each : computed.results) {
      const std::vector<ComputePart> parts = each.parts();
      if (parts.empty()) continue;
      report << "split across backends:";
      for (const ComputePart& p : parts)
        report << " " << backend_name(p.backend) << " states " << p.first_state << "-"
               << p.first_state + p.num_states - 1 << " (" << p.compute_us << " us)";
      report << "\n";
    }
    report << std::fixed << std::setprecision(1);
    report << "server timings" << (requests_ok > 1 ? " (mean per request)" : "") << ": queue "
           << per_request(static_cast<double>(computed.sum.queue_us)) << " us, compute "
           << per_request(static_cast<double>(computed.sum.compute_us)) << " us, total "
           << per_request(static_cast<double>(computed.sum.total_us)) << " us\n";
    report << "client round trip" << (requests_ok > 1 ? " (mean per request)" : "") << ": "
           << per_request(computed.sum.round_trip_us) << " us\n";
  }
  report << "checks: " << (nonfinite == 0 ? "all outputs finite" : std::to_string(nonfinite) + " non-finite values")
         << (failed ? ", " + std::to_string(failed) + " states failed" : "") << "\n";
  return failed > 0 || nonfinite > 0 ? 1 : 0;
}

}  // namespace rbdgrad::cli
