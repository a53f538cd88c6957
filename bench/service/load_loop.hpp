// The measuring loops of service_load: K gRPC callers on K threads (warm-up, then timed calls until
// the request count or the time cap), and the in-process loop that times each step of the daemon's
// computation and, separately, the protobuf (de)serialisation a gRPC round trip adds.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "grpc_callers.hpp"
#include "in_process_compute.hpp"
#include "latency_stats.hpp"
#include "load_options.hpp"

namespace rbdgrad::bench {

// How long one row (one N) runs.
struct LoadPlan {
  unsigned concurrency = 1;      // callers, one thread each
  std::uint64_t warmup = 0;      // untimed calls per caller
  std::uint64_t requests = 1;    // timed calls over all callers (each makes its share, rounded up)
  double duration_s = 0;         // also stop the timed calls after this long; 0 = no cap
  double idle_us = 0;            // in-process only: sleep between requests (untimed)
};

struct LoadResult {
  LatencySummary latency;        // per call, over all callers
  double wall_s = 0;             // first timed call started -> last one ended
  double requests_per_s = 0;     // timed calls / wall_s
  // the server's own timings of the timed calls (Dynamics responses; count 0 otherwise)
  LatencySummary server_queue, server_compute, server_total;
};

/// Runs `plan.concurrency` callers made by `make_caller` (on their own threads, so a stream is
/// opened by the thread that uses it). Every response is checked after its call; the first failure
/// stops all callers and is returned.
Status run_callers(const std::function<std::unique_ptr<Caller>()>& make_caller, const LoadPlan& plan, LoadResult& out);

struct InProcessResult {
  LoadResult total;              // from_request + compute + to_response, per request
  LatencySummary from_request, compute, to_response;  // the same requests, step by step
  LatencySummary compute_alone;  // compute on a batch prepared once (no conversion at all)
  LatencySummary marshal;        // serialise + parse the request, then the response (both ends' protobuf work)
};

/// Times the daemon's computation of `request` in-process (see InProcessResult), `plan.warmup`
/// untimed runs first. Every response is checked with `check`.
Status run_in_process(InProcessCompute& compute, const v1::ComputeRequest& request, rbdgrad_precision precision,
                      const LoadPlan& plan, const std::function<Status(const v1::ComputeResponse&)>& check,
                      InProcessResult& out);

}  // namespace rbdgrad::bench
