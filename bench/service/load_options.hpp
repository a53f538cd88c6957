// The options of service_load: what to call (a Dynamics or Echo server, or the same computation
// in-process), how (unary or stream, concurrency) and how long, parsed from the command line.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::bench {

enum class LoadService { kDynamics, kEcho, kInProcess };
enum class CallMode { kUnary, kStream };

struct LoadOptions {
  LoadService service = LoadService::kDynamics;
  std::string target;                            // gRPC target ("127.0.0.1:50051", "unix:/path"); unused in-process
  CallMode mode = CallMode::kUnary;              // in-process ignores it
  std::vector<std::uint32_t> sizes = {1, 16, 64, 128, 1024};  // N per request, one result row each
  std::string model = "iiwa14";                  // the server's model name, loaded locally by the same name
  std::vector<v1::Output> outputs = {v1::OUTPUT_DQDD_DQ, v1::OUTPUT_DQDD_DQD};
  v1::InputKind input_kind = v1::INPUT_KIND_TAU;
  v1::Precision precision = v1::PRECISION_F64;   // never AUTO: the in-process path needs it resolved
  rbdgrad_precision plugin_precision = RBDGRAD_PRECISION_F64;  // the same, in the plugin ABI
  unsigned concurrency = 1;                      // callers with a request in flight; 1 = latency mode
  std::uint64_t warmup = 50;                     // untimed calls per caller before measuring, per N
  std::uint64_t requests = 2000;                 // measured calls per N, over all callers
  double duration_s = 0;                         // time cap per N in seconds (0 = none): ends a row early
  unsigned threads = 0;                          // in-process CPU plugin threads; 0 = all cores, as rbdgradd
  double idle_us = 0;                            // in-process: sleep between requests, as a round trip would
  std::string plugin;                            // the CPU plugin (librbdgrad_cpu.so)
  bool reference = true;                         // compare Dynamics responses with the in-process result
  double tolerance = 1e-9;                       // relative, for that comparison
  std::uint32_t seed = 1;                        // of the random states
  bool tsv = false;                              // tab-separated output for scripts
};

/// Parses argv[1, argc) into `out` (defaults above; `default_plugin` fills out.plugin).
/// \return "" on success, "help" when --help was given (usage already printed), else the problem.
std::string parse_load_options(int argc, const char* const* argv, const std::string& default_plugin, LoadOptions& out);

// "unary" / "stream"; "dynamics" / "echo" / "in-process"
const char* mode_name(CallMode mode);
const char* service_name(LoadService service);
// "dqdd_dq,dqdd_dqd": the names --outputs takes
std::string outputs_text(const std::vector<v1::Output>& outputs);

}  // namespace rbdgrad::bench
