#include "calibration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <random>
#include <stdexcept>
#include <thread>

#include "request_batch.hpp"


namespace rbdgrad::server {

namespace {

namespace v1 = rbdgrad::v1;

// FNV-1a, 64 bits
struct Hash {
  std::uint64_t h = 14695981039346656037ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ c[k]) * 1099511628211ull;
  }
  void text(const std::string& s) {
    const std::uint64_t n = s.size();
    bytes(&n, sizeof n);
    bytes(s.data(), s.size());
  }
  template <class T>
  void array(const T* p, std::size_t n) {
    bytes(&n, sizeof n);
    if (p != nullptr) bytes(p, n * sizeof(T));
  }
  std::string hex() const {
    char out[17];
    std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(h));
    return out;
  }
};

std::string cpu_model_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 1);
  return "unknown cpu";
}

// n random states of the gradient request, converted into `precision` as the daemon converts a
// request (RequestBatch): q within half the joints' limits (the whole circle's half for unlimited
// ones), qd and tau in [-0.5, 0.5], moderate enough for Q16.16
RequestBatch calibration_batch(const ServedModel& model, std::uint32_t precision, std::uint64_t n) {
  const std::size_t nv = static_cast<std::size_t>(model.model.nv);
  std::mt19937_64 rng(n * 7919 + nv);
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  std::vector<double> q(n * nv), qd(n * nv), tau(n * nv);
  for (std::size_t e = 0; e < q.size(); ++e) {
    const JointInfo& joint = model.model.joints[e % nv];
    const bool limited = joint.upper_limit > joint.lower_limit;
    const double mid = limited ? 0.5 * (joint.lower_limit + joint.upper_limit) : 0.0;
    const double half = limited ? 0.5 * (joint.upper_limit - joint.lower_limit) : M_PI;
    q[e] = mid + half * unit(rng);
    qd[e] = unit(rng);
    tau[e] = unit(rng);
  }
  v1::ComputeRequest request;
  request.set_num_states(static_cast<std::uint32_t>(n));
  request.set_input_kind(v1::INPUT_KIND_TAU);
  // a scene's batches follow its plan (ABI 1.3): its outputs, M^-1 when supplied (the identity:
  // the time does not depend on it), forces when it has force links (zero)
  const std::uint32_t gradient = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  std::uint32_t outputs = gradient;
  std::vector<double> minv, fext;
  if (model.scene) {
    outputs = (model.scene->outputs & gradient) != 0 ? model.scene->outputs & gradient : model.scene->outputs;
    if (model.scene->minv_supplied) {
      minv.assign(n * nv * nv, 0.0);
      for (std::size_t e = 0; e < minv.size(); e += nv + 1) minv[e] = 1.0;
    }
    if (!model.scene->force_bodies.empty()) fext.assign(n * nv * 6, 0.0);
  }
  for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1)
    if (outputs & flag) request.add_outputs(output_enum(flag));
  for (const auto& [tensor, values] : {std::pair{request.mutable_q(), &q}, std::pair{request.mutable_qd(), &qd},
                                       std::pair{request.mutable_u(), &tau}, std::pair{request.mutable_minv(), &minv},
                                       std::pair{request.mutable_fext(), &fext}}) {
    if (values->empty()) continue;
    tensor->set_type(v1::SCALAR_TYPE_F64);
    tensor->set_data(values->data(), values->size() * sizeof(double));
  }
  RequestBatch batch;
  // the states are valid by construction: an error here is a bug
  if (Status s = RequestBatch::from_request(request, model.model.nv, static_cast<rbdgrad_precision>(precision),
                                            static_cast<std::uint32_t>(n), batch);
      !s)
    throw std::logic_error("calibration batch: " + s.message());
  return batch;
}

// The sweep, as one job: it has one instance to itself for the whole sweep.
class SweepJob : public PoolJob {
 public:
  SweepJob(const ServedModel& model, std::uint32_t precision, const CalibrationOptions& options)
      : model_(model), precision_(precision), options_(options) {}

  void run(PluginInstance& instance) noexcept override {
    Status status = Status::ok();
    try {
      for (const std::uint64_t n : options_.sizes) {
        const RequestBatch batch = calibration_batch(model_, precision_, n);
        std::vector<double> us;
        for (int r = 0; r <= options_.repetitions; ++r) {
          const auto start = std::chrono::steady_clock::now();
          const Status s = instance.compute(batch.batch());
          const double t = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
          // a state the precision cannot hold (fixed-point range) still took its time
          if (!s && s.code() != StatusCode::kOutOfRange && s.code() != StatusCode::kFailedPrecondition) {
            status = Status(s.code(), "N = " + std::to_string(n) + ": " + s.message());
            break;
          }
          if (r > 0) us.push_back(t);  // the first call warms up
        }
        if (!status) break;
        std::nth_element(us.begin(), us.begin() + static_cast<long>(us.size() / 2), us.end());
        const double median = us[us.size() / 2];
        points_.push_back({n, median});
        if (median > options_.max_call_us) break;
      }
    } catch (const std::exception& e) {
      status = Status(StatusCode::kInternal, std::string("calibration: ") + e.what());
    }
    done_.set_value(status);  // last: the waiting thread may destroy the job after this
  }

  std::future<Status> done() { return done_.get_future(); }
  std::vector<LatencyModel::Point> points_;

 private:
  const ServedModel& model_;
  const std::uint32_t precision_;
  const CalibrationOptions options_;
  std::promise<Status> done_;
};

}  // namespace

std::string backend_fingerprint(const BackendState& backend) {
  Hash h;
  h.text(backend.name);
  h.text(backend.info.version);
  h.text(backend.description.mode);
  h.text(backend.description.device);
  h.text(backend.options);
  h.text(cpu_model_name());
  h.text(std::to_string(std::thread::hardware_concurrency()));
  return h.hex();
}

std::string model_fingerprint(const ServedModel& model) {
  const rbdgrad_model_desc& d = model.desc.desc();
  const std::size_t n = d.nv;
  Hash h;
  h.array(d.parent, n);
  h.array(d.joint_type, n);
  h.array(d.joint_rotation, 9 * n);
  h.array(d.joint_translation, 3 * n);
  h.array(d.mass, n);
  h.array(d.com, 3 * n);
  h.array(d.inertia_com, 9 * n);
  h.array(d.gravity, 3);
  return h.hex();
}

Status measure_latency(InstancePool& pool, const ServedModel& model, std::uint32_t precision,
                       const CalibrationOptions& options, LatencyModel& out) {
  SweepJob job(model, precision, options);
  std::future<Status> done = job.done();
  pool.submit(job, 0);
  const Status s = done.get();
  if (!s) return s;
  out = LatencyModel(job.points_);
  return Status::ok();
}

Status estimated_latency(const PluginInstance& instance, std::uint32_t precision, const CalibrationOptions& options,
                         LatencyModel& out) {
  std::vector<LatencyModel::Point> points;
  for (const std::uint64_t n : options.sizes) {
    double us = 0;
    if (Status s = instance.estimate_latency(precision, RBDGRAD_INPUT_TAU, n, us); !s) return s;
    points.push_back({n, us});
  }
  out = LatencyModel(std::move(points));
  return Status::ok();
}

}  // namespace rbdgrad::server
