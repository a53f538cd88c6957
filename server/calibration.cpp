#include "calibration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <future>
#include <random>
#include <thread>

#include "common/batch_view.hpp"


namespace rbdgrad::server {

namespace {

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

// n random states of the gradient request, in `precision`: q within half the joints' limits (the
// whole circle's half for unlimited ones), qd and tau in [-0.5, 0.5], moderate enough for Q16.16
struct CalibrationBatch {
  std::vector<unsigned char> q, qd, tau, qdd, dq, dqd;
  std::vector<std::int32_t> status;
  rbdgrad_batch raw{};

  CalibrationBatch(const ServedModel& model, std::uint32_t precision, std::uint64_t n) {
    const std::size_t nv = static_cast<std::size_t>(model.model.nv), size = plugin::scalar_bytes(precision);
    const std::size_t vec = n * nv;
    std::mt19937_64 rng(n * 7919 + nv);
    std::uniform_real_distribution<double> unit(-0.5, 0.5);
    auto fill = [&](std::vector<unsigned char>& to, auto value_of) {
      to.resize(vec * size);
      for (std::size_t e = 0; e < vec; ++e) {
        const double x = value_of(e % nv);
        if (precision == RBDGRAD_PRECISION_F64) {
          std::memcpy(to.data() + e * size, &x, size);
        } else if (precision == RBDGRAD_PRECISION_F32) {
          const float f = static_cast<float>(x);
          std::memcpy(to.data() + e * size, &f, size);
        } else {
          const std::int32_t raw_value = static_cast<std::int32_t>(std::lround(x * 65536.0));
          std::memcpy(to.data() + e * size, &raw_value, size);
        }
      }
    };
    fill(q, [&](std::size_t j) {
      const JointInfo& joint = model.model.joints[j];
      const bool limited = joint.upper_limit > joint.lower_limit;
      const double mid = limited ? 0.5 * (joint.lower_limit + joint.upper_limit) : 0.0;
      const double half = limited ? 0.5 * (joint.upper_limit - joint.lower_limit) : M_PI;
      return mid + half * unit(rng);
    });
    fill(qd, [&](std::size_t) { return unit(rng); });
    fill(tau, [&](std::size_t) { return unit(rng); });
    qdd.resize(vec * size);
    dq.resize(vec * nv * size);
    dqd.resize(vec * nv * size);
    status.resize(n);
    raw.struct_size = sizeof(raw);
    raw.n = n;
    raw.precision = precision;
    raw.input_kind = RBDGRAD_INPUT_TAU;
    raw.outputs = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
    raw.q = q.data();
    raw.qd = qd.data();
    raw.u = tau.data();
    raw.qdd = qdd.data();
    raw.dqdd_dq = dq.data();
    raw.dqdd_dqd = dqd.data();
    raw.state_status = status.data();
  }
};

// The sweep, as one job: it has one instance to itself for the whole sweep.
class SweepJob : public PoolJob {
 public:
  SweepJob(const ServedModel& model, std::uint32_t precision, const CalibrationOptions& options)
      : model_(model), precision_(precision), options_(options) {}

  void run(PluginInstance& instance) noexcept override {
    Status status = Status::ok();
    try {
      for (const std::uint64_t n : options_.sizes) {
        CalibrationBatch batch(model_, precision_, n);
        std::vector<double> us;
        for (int r = 0; r <= options_.repetitions; ++r) {
          const auto start = std::chrono::steady_clock::now();
          const Status s = instance.compute(batch.raw);
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
