// The in-process computation of service_load (see in_process_compute.hpp).
#include "in_process_compute.hpp"

#include <chrono>
#include <limits>
#include <map>

namespace rbdgrad::bench {
namespace {

using Clock = std::chrono::steady_clock;

double micros(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// no limit of its own: the benchmark's N are the daemon's business
constexpr std::uint32_t kNoStateLimit = std::numeric_limits<std::uint32_t>::max();

}  // namespace

Status InProcessCompute::create(const std::string& plugin_path, const Model& model, unsigned threads,
                                std::unique_ptr<InProcessCompute>& out) {
  std::unique_ptr<InProcessCompute> made(new InProcessCompute());
  made->nv_ = model.nv;
  if (Status s = server::Plugin::load(plugin_path, made->plugin_); !s) return s;
  made->desc_ = std::make_unique<plugin::ModelDesc>(model);
  std::map<std::string, std::string> options;
  if (threads > 0) options["threads"] = std::to_string(threads);
  if (Status s = made->plugin_->create_instance(made->desc_->desc(), options, made->instance_); !s)
    return Status(s.code(), plugin_path + ": " + s.message());
  out = std::move(made);
  return Status::ok();
}

Status InProcessCompute::prepare(const v1::ComputeRequest& request, rbdgrad_precision precision,
                                 server::RequestBatch& out) const {
  return server::RequestBatch::from_request(request, nv_, precision, kNoStateLimit, out);
}

Status InProcessCompute::run(const v1::ComputeRequest& request, rbdgrad_precision precision,
                             v1::ComputeResponse& response, StageTimes* times) {
  const Clock::time_point t0 = Clock::now();
  server::RequestBatch batch;
  if (Status s = prepare(request, precision, batch); !s) return s;
  const Clock::time_point t1 = Clock::now();
  if (Status s = instance_->compute(batch.batch()); !s) return s;
  const Clock::time_point t2 = Clock::now();
  response.Clear();
  batch.to_response(response, v1::SCALAR_TYPE_F64);
  const Clock::time_point t3 = Clock::now();
  if (times) *times = {micros(t0, t1), micros(t1, t2), micros(t2, t3)};
  return Status::ok();
}

}  // namespace rbdgrad::bench
