// Command-line parsing for service_load (see load_options.hpp).
#include "load_options.hpp"

#include <array>
#include <charconv>
#include <iostream>
#include <set>
#include <string_view>

#include "args.hpp"

namespace rbdgrad::bench {
namespace {

constexpr rbdgrad::cli::OptionSpec kOptions[] = {
    {"target", "ADDR", "gRPC target: 127.0.0.1:PORT or unix:/path (not for --service in-process)"},
    {"service", "NAME", "dynamics (rbdgradd), echo (echo_server) or in-process; default dynamics"},
    {"mode", "unary|stream", "Compute / Echo.Unary, or one long-lived bidi stream per caller; default unary"},
    {"n", "LIST", "states per request, comma-separated; default 1,16,64,128,1024"},
    {"model", "NAME", "model name on the server, loaded locally by the same name; default iiwa14"},
    {"outputs", "LIST", "subset of qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd; default dqdd_dq,dqdd_dqd"},
    {"input", "tau|qdd", "what u holds; default tau"},
    {"precision", "f64|f32|fixed", "compute precision (outputs always travel as f64); default f64"},
    {"concurrency", "K", "callers with one request in flight each (throughput); default 1 (latency)"},
    {"warmup", "COUNT", "untimed calls per caller before each N; default 50"},
    {"requests", "COUNT", "measured calls per N over all callers; default 2000"},
    {"duration-s", "SEC", "also stop measuring an N after this many seconds; default 0 = no cap"},
    {"threads", "T", "in-process CPU plugin threads; default 0 = all cores (rbdgradd's default)"},
    {"idle-us", "US", "in-process: sleep this long between requests (as a round trip idles the workers); default 0"},
    {"plugin", "PATH", "the CPU plugin for in-process runs and the reference; default the build's"},
    {"no-reference", "", "do not compare Dynamics responses with in-process results (still checks sizes, finiteness)"},
    {"tol", "REL", "relative tolerance of that comparison; default 1e-9 (the CPU backend is exact)"},
    {"seed", "S", "seed of the random states; default 1"},
    {"tsv", "", "tab-separated rows with a header line, for scripts"},
    {"help", "", "show this help"},
};

struct OutputName {
  std::string_view name;
  v1::Output output;
};
// the names of rbdgrad eval --outputs, in its order
constexpr std::array<OutputName, 8> kOutputNames{{
    {"qdd", v1::OUTPUT_QDD},
    {"M", v1::OUTPUT_M},
    {"Minv", v1::OUTPUT_MINV},
    {"dqdd_dq", v1::OUTPUT_DQDD_DQ},
    {"dqdd_dqd", v1::OUTPUT_DQDD_DQD},
    {"tau_id", v1::OUTPUT_TAU},
    {"dtau_dq", v1::OUTPUT_DTAU_DQ},
    {"dtau_dqd", v1::OUTPUT_DTAU_DQD},
}};

template <class T>
bool parse_number(std::string_view text, T& out) {
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && ptr == end;
}

void print_help(std::ostream& os) {
  os << "usage: service_load --service dynamics|echo --target ADDR [options]\n"
     << "       service_load --service in-process [options]\n\n"
     << "End-to-end latency (p50, p99, mean) and throughput of rbdgradd, of the echo floor, or of the same\n"
     << "computation in-process, one row per N. Every response is checked (status, sizes, finite values;\n"
     << "Dynamics responses also against the in-process result) outside the timed region.\n\noptions:\n"
     << rbdgrad::cli::format_options(kOptions);
}

}  // namespace

const char* mode_name(CallMode mode) { return mode == CallMode::kUnary ? "unary" : "stream"; }

const char* service_name(LoadService service) {
  switch (service) {
    case LoadService::kDynamics: return "dynamics";
    case LoadService::kEcho: return "echo";
    case LoadService::kInProcess: return "in-process";
  }
  return "?";
}

std::string outputs_text(const std::vector<v1::Output>& outputs) {
  std::string text;
  for (v1::Output o : outputs)
    for (const OutputName& n : kOutputNames)
      if (n.output == o) {
        if (!text.empty()) text += ',';
        text += n.name;
      }
  return text;
}

std::string parse_load_options(int argc, const char* const* argv, const std::string& default_plugin, LoadOptions& out) {
  rbdgrad::cli::Args args;
  if (std::string error = rbdgrad::cli::Args::parse(kOptions, argc, argv, 1, args); !error.empty()) return error;
  if (args.has("help")) {
    print_help(std::cout);
    return "help";
  }
  out.plugin = args.value_or("plugin", default_plugin);
  out.target = args.value_or("target", "");
  out.model = args.value_or("model", out.model);
  out.reference = !args.has("no-reference");
  out.tsv = args.has("tsv");

  const std::string service = args.value_or("service", "dynamics");
  if (service == "dynamics") out.service = LoadService::kDynamics;
  else if (service == "echo") out.service = LoadService::kEcho;
  else if (service == "in-process") out.service = LoadService::kInProcess;
  else return "--service must be dynamics, echo or in-process, not '" + service + "'";
  if (out.service != LoadService::kInProcess && out.target.empty()) return "--service " + service + " needs --target";

  const std::string mode = args.value_or("mode", "unary");
  if (mode == "unary") out.mode = CallMode::kUnary;
  else if (mode == "stream") out.mode = CallMode::kStream;
  else return "--mode must be unary or stream, not '" + mode + "'";

  if (const std::string* list = args.value("n")) {
    out.sizes.clear();
    for (const std::string& item : rbdgrad::cli::split_list(*list)) {
      std::uint32_t n = 0;
      if (!parse_number(item, n) || n == 0) return "--n: '" + item + "' is not a positive integer";
      out.sizes.push_back(n);
    }
    if (out.sizes.empty()) return "--n is empty";
  }

  if (const std::string* list = args.value("outputs")) {
    out.outputs.clear();
    std::set<v1::Output> seen;
    for (const std::string& item : rbdgrad::cli::split_list(*list)) {
      const OutputName* found = nullptr;
      for (const OutputName& n : kOutputNames)
        if (n.name == item) found = &n;
      if (!found) return "--outputs: unknown output '" + item + "' (qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd)";
      if (!seen.insert(found->output).second) return "--outputs: '" + item + "' given twice";
      out.outputs.push_back(found->output);
    }
    if (out.outputs.empty()) return "--outputs is empty";
  }

  const std::string input = args.value_or("input", "tau");
  if (input == "tau") out.input_kind = v1::INPUT_KIND_TAU;
  else if (input == "qdd") out.input_kind = v1::INPUT_KIND_QDD;
  else return "--input must be tau or qdd, not '" + input + "'";

  const std::string precision = args.value_or("precision", "f64");
  if (precision == "f64") out.precision = v1::PRECISION_F64, out.plugin_precision = RBDGRAD_PRECISION_F64;
  else if (precision == "f32") out.precision = v1::PRECISION_F32, out.plugin_precision = RBDGRAD_PRECISION_F32;
  else if (precision == "fixed") out.precision = v1::PRECISION_FIXED, out.plugin_precision = RBDGRAD_PRECISION_FIXED_Q16_16;
  else return "--precision must be f64, f32 or fixed, not '" + precision + "'";

  // the unsigned counts: "name" -> field, with its least value
  struct Count {
    const char* name;
    std::uint64_t* value;
    std::uint64_t min;
  };
  std::uint64_t concurrency = out.concurrency, threads = out.threads, seed = out.seed;
  for (const Count& c : {Count{"concurrency", &concurrency, 1}, Count{"warmup", &out.warmup, 0},
                         Count{"requests", &out.requests, 1}, Count{"threads", &threads, 0}, Count{"seed", &seed, 0}}) {
    if (const std::string* text = args.value(c.name))
      if (!parse_number(*text, *c.value) || *c.value < c.min)
        return std::string("--") + c.name + ": '" + *text + "' is not an integer >= " + std::to_string(c.min);
  }
  if (concurrency > 1024) return "--concurrency: at most 1024";
  if (threads > 1024) return "--threads: at most 1024";
  if (seed > UINT32_MAX) return "--seed: at most 4294967295";
  out.concurrency = static_cast<unsigned>(concurrency);
  out.threads = static_cast<unsigned>(threads);
  out.seed = static_cast<std::uint32_t>(seed);
  if (out.service == LoadService::kInProcess && out.concurrency != 1)
    return "--concurrency: in-process runs one caller (a plugin instance computes one batch at a time)";

  // doubles: from_chars for double is in GCC 12's libstdc++
  if (const std::string* text = args.value("duration-s"))
    if (!parse_number(*text, out.duration_s) || !(out.duration_s >= 0)) return "--duration-s: '" + *text + "' is not a number >= 0";
  if (const std::string* text = args.value("idle-us"))
    if (!parse_number(*text, out.idle_us) || !(out.idle_us >= 0)) return "--idle-us: '" + *text + "' is not a number >= 0";
  if (const std::string* text = args.value("tol"))
    if (!parse_number(*text, out.tolerance) || !(out.tolerance >= 0)) return "--tol: '" + *text + "' is not a number >= 0";
  return "";
}

}  // namespace rbdgrad::bench
