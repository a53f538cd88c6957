// service_load: end-to-end latency (p50, p99, mean) and throughput of rbdgradd's Dynamics service,
// of the echo floor (echo_server) or of the same computation in-process, one row per batch size N.
// bench/README.md explains the options and run_service_bench.sh combines the three.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "echo.grpc.pb.h"
#include "grpc_callers.hpp"
#include "in_process_compute.hpp"
#include "load_loop.hpp"
#include "load_options.hpp"
#include "model_source.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"
#include "response_check.hpp"
#include "workload.hpp"

namespace {

using namespace rbdgrad::bench;
namespace v1 = rbdgrad::v1;

// One output row. Step columns are in-process only (negative = not measured, printed "-"); server_*
// columns are the p50 of the timings a Dynamics server reports in its responses.
struct Row {
  std::uint32_t n = 0;
  std::size_t request_bytes = 0, response_bytes = 0;
  LoadResult load;
  double from_request_p50 = -1, compute_p50 = -1, to_response_p50 = -1;
  double compute_alone_p50 = -1, compute_alone_p99 = -1, marshal_p50 = -1;
};

constexpr const char* kColumns[] = {"n", "req_bytes", "resp_bytes", "count", "p50_us", "p99_us", "mean_us",
                                    "max_us", "req_per_s", "states_per_s", "from_request_p50_us",
                                    "compute_p50_us", "to_response_p50_us", "compute_alone_p50_us",
                                    "compute_alone_p99_us", "marshal_p50_us", "server_queue_p50_us",
                                    "server_compute_p50_us", "server_total_p50_us"};

std::string number(double v, int decimals) {
  if (v < 0) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// a server-reported p50 (whole µs on the wire), "-" when the responses carried none
std::string server(const LatencySummary& s) { return s.count ? number(s.p50_us, 0) : "-"; }

std::vector<std::string> cells(const Row& r) {
  const LatencySummary& l = r.load.latency;
  return {std::to_string(r.n), std::to_string(r.request_bytes), std::to_string(r.response_bytes),
          std::to_string(l.count), number(l.p50_us, 1), number(l.p99_us, 1), number(l.mean_us, 1),
          number(l.max_us, 1), number(r.load.requests_per_s, 0), number(r.load.requests_per_s * r.n, 0),
          number(r.from_request_p50, 1), number(r.compute_p50, 1), number(r.to_response_p50, 1),
          number(r.compute_alone_p50, 1), number(r.compute_alone_p99, 1), number(r.marshal_p50, 1),
          server(r.load.server_queue), server(r.load.server_compute), server(r.load.server_total)};
}

void print_line(const std::vector<std::string>& items, bool tsv) {
  std::string line;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (tsv) {
      line += (i ? "\t" : "") + items[i];
    } else {
      // right-aligned to the header's width (at least 8)
      const std::size_t width = std::max<std::size_t>(8, std::string(kColumns[i]).size());
      line += (i ? "  " : "") + std::string(width > items[i].size() ? width - items[i].size() : 0, ' ') + items[i];
    }
  }
  std::cout << line << "\n" << std::flush;
}

int fail(const std::string& message) {
  std::cerr << "service_load: " << message << "\n";
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  LoadOptions opt;
  if (std::string error = parse_load_options(argc, argv, RBDGRAD_CPU_PLUGIN_PATH, opt); !error.empty()) {
    if (error == "help") return 0;
    std::cerr << "service_load: " << error << " (--help lists the options)\n";
    return 2;
  }

  rbdgrad::Model model;
  if (rbdgrad::Status s = rbdgrad::cli::load_model(opt.model, std::nullopt, model); !s) return fail(s.to_string());
  const std::uint32_t max_n = *std::max_element(opt.sizes.begin(), opt.sizes.end());
  const StatePool pool = make_state_pool(model, max_n, opt.input_kind, opt.seed);

  // the in-process computation: the baseline itself, or the reference for the server's answers
  std::unique_ptr<InProcessCompute> in_process;
  const bool in_process_run = opt.service == LoadService::kInProcess;
  if (in_process_run || (opt.service == LoadService::kDynamics && opt.reference)) {
    // one worker is enough for a reference and leaves the cores to the server
    const unsigned threads = in_process_run ? opt.threads : 1;
    if (rbdgrad::Status s = InProcessCompute::create(opt.plugin, model, threads, in_process); !s)
      return fail(s.to_string() + (in_process_run ? "" : " (--no-reference skips the comparison)"));
  }

  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::Dynamics::Stub> dynamics;
  std::unique_ptr<Echo::Stub> echo;
  if (!in_process_run) {
    channel = make_channel(opt.target);
    if (rbdgrad::Status s = wait_connected(*channel, opt.target, 10.0); !s) return fail(s.message());
    dynamics = v1::Dynamics::NewStub(channel);
    echo = Echo::NewStub(channel);
  }

  std::cout << "# service_load service=" << service_name(opt.service)
            << (in_process_run ? "" : std::string(" target=") + opt.target + " mode=" + mode_name(opt.mode))
            << " model=" << opt.model << " nv=" << model.nv << " outputs=" << outputs_text(opt.outputs)
            << " input=" << (opt.input_kind == v1::INPUT_KIND_TAU ? "tau" : "qdd")
            << " precision=" << v1::Precision_Name(opt.precision) << " concurrency=" << opt.concurrency
            << " warmup=" << opt.warmup << " requests=" << opt.requests << " duration_s=" << opt.duration_s
            << (in_process_run ? " threads=" + std::to_string(opt.threads) + " (0 = all cores) idle_us=" + number(opt.idle_us, 0) : "")
            << "\n";
  print_line(std::vector<std::string>(std::begin(kColumns), std::end(kColumns)), opt.tsv);

  const LoadPlan plan{opt.concurrency, opt.warmup, opt.requests, opt.duration_s, opt.idle_us};
  for (std::uint32_t n : opt.sizes) {
    const v1::ComputeRequest request = make_compute_request(pool, n, opt);
    Row row;
    row.n = n;
    row.request_bytes = request.ByteSizeLong();
    row.response_bytes = expected_response_bytes(request, model.nv);

    std::optional<v1::ComputeResponse> reference;
    if (in_process && !in_process_run) {
      reference.emplace();
      if (rbdgrad::Status s = in_process->run(request, opt.plugin_precision, *reference); !s)
        return fail("N=" + std::to_string(n) + ": in-process reference: " + s.to_string());
    }
    const auto check_compute = [&](const v1::ComputeResponse& r) {
      return check_compute_response(request, model.nv, r, reference ? &*reference : nullptr, opt.tolerance);
    };

    rbdgrad::Status status;
    switch (opt.service) {
      case LoadService::kDynamics:
        status = run_callers([&] { return make_dynamics_caller(*dynamics, opt.mode, request, check_compute); }, plan,
                             row.load);
        break;
      case LoadService::kEcho: {
        const EchoRequest echo_request = make_echo_request(row.request_bytes, row.response_bytes);
        // the sizes that actually travel (equal to the Dynamics ones, or a byte off)
        row.request_bytes = echo_request.ByteSizeLong();
        EchoResponse probe;
        probe.mutable_payload()->resize(echo_request.response_bytes());
        row.response_bytes = probe.ByteSizeLong();
        const auto check_echo = [&](const EchoResponse& r) { return check_echo_response(echo_request, r); };
        status = run_callers([&] { return make_echo_caller(*echo, opt.mode, echo_request, check_echo); }, plan, row.load);
        break;
      }
      case LoadService::kInProcess: {
        InProcessResult result;
        status = run_in_process(*in_process, request, opt.plugin_precision, plan, check_compute, result);
        row.load = result.total;
        row.from_request_p50 = result.from_request.p50_us;
        row.compute_p50 = result.compute.p50_us;
        row.to_response_p50 = result.to_response.p50_us;
        row.compute_alone_p50 = result.compute_alone.p50_us;
        row.compute_alone_p99 = result.compute_alone.p99_us;
        row.marshal_p50 = result.marshal.p50_us;
        break;
      }
    }
    if (!status) return fail("N=" + std::to_string(n) + ": " + status.to_string());
    print_line(cells(row), opt.tsv);
  }
  return 0;
}
