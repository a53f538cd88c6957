// The daemon's computation without the transport: a ComputeRequest through the CPU plugin loaded
// with dlopen (server/plugin_loader.hpp), converted and answered by server/request_batch.hpp, as
// rbdgradd does for each request. service_load times it (the in-process baseline) and uses its
// response as the reference a server's answer must match.
#pragma once

#include <memory>
#include <string>

#include "common/model_desc.hpp"
#include "plugin_loader.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"
#include "request_batch.hpp"

namespace rbdgrad::bench {

// Wall-clock time of each step of one request, microseconds.
struct StageTimes {
  double from_request_us = 0;  // RequestBatch::from_request: validation and conversion of the inputs
  double compute_us = 0;       // PluginInstance::compute
  double to_response_us = 0;   // RequestBatch::to_response: outputs into the response message
};

class InProcessCompute {
 public:
  /// Loads the plugin at `plugin_path` and prepares `model` on it with `threads` workers (0 = the
  /// plugin's default, all cores). Errors name the plugin path.
  static Status create(const std::string& plugin_path, const Model& model, unsigned threads,
                       std::unique_ptr<InProcessCompute>& out);

  /// One request the daemon's way: from_request, compute, to_response into `response` (which is
  /// cleared first). `times`, when given, receives the steps' durations.
  Status run(const v1::ComputeRequest& request, rbdgrad_precision precision, v1::ComputeResponse& response,
             StageTimes* times = nullptr);

  /// compute alone on a batch prepared by RequestBatch::from_request.
  Status compute(server::RequestBatch& batch) { return instance_->compute(batch.batch()); }

  /// The request converted for compute(), as run() does it.
  Status prepare(const v1::ComputeRequest& request, rbdgrad_precision precision, server::RequestBatch& out) const;

  int nv() const { return nv_; }

 private:
  InProcessCompute() = default;

  int nv_ = 0;
  std::unique_ptr<server::Plugin> plugin_;
  std::unique_ptr<plugin::ModelDesc> desc_;
  std::unique_ptr<server::PluginInstance> instance_;
};

}  // namespace rbdgrad::bench
