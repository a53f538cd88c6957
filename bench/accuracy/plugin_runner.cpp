#include "plugin_runner.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

#include "common/batch_view.hpp"
#include "common/model_desc.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::bench {
namespace {

// The inputs of a batch in the storage type of one precision, and its outputs.
class TypedBatch {
 public:
  TypedBatch(const StateSet& s, std::uint32_t precision) : precision_(precision), nv_(s.nv), n_(s.n) {
    const std::size_t vec = s.n * static_cast<std::size_t>(s.nv), mat = vec * static_cast<std::size_t>(s.nv);
    const std::size_t scalar = plugin::scalar_bytes(precision);
    q_ = encode(s.q);
    qd_ = encode(s.qd);
    tau_ = encode(s.tau);
    qdd_.resize(vec * scalar);
    dq_.resize(mat * scalar);
    dqd_.resize(mat * scalar);
    status_.assign(s.n, 0);
  }

  // states [first, first + n) as one batch
  rbdgrad_batch batch(std::size_t first, std::size_t n) {
    rbdgrad_batch b{};
    b.struct_size = sizeof b;
    b.n = n_;
    b.precision = precision_;
    b.input_kind = RBDGRAD_INPUT_TAU;
    b.outputs = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
    b.q = q_.data();
    b.qd = qd_.data();
    b.u = tau_.data();
    b.qdd = qdd_.data();
    b.dqdd_dq = dq_.data();
    b.dqdd_dqd = dqd_.data();
    b.state_status = status_.data();
    return plugin::states_of(b, nv_, first, n);
  }

  void decode(Gradients& out) const {
    out.dqdd_dq = to_double(dq_);
    out.dqdd_dqd = to_double(dqd_);
    out.state_status = status_;
  }

 private:
  std::vector<std::byte> encode(const std::vector<double>& values) const {
    std::vector<std::byte> out(values.size() * plugin::scalar_bytes(precision_));
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (precision_ == RBDGRAD_PRECISION_F64) {
        std::memcpy(out.data() + i * sizeof(double), &values[i], sizeof(double));
      } else if (precision_ == RBDGRAD_PRECISION_F32) {
        const auto f = static_cast<float>(values[i]);
        std::memcpy(out.data() + i * sizeof(float), &f, sizeof(float));
      } else {
        // an input out of the format's range saturates and is flagged by the backend's own check
        const std::int32_t raw = Q16_16(values[i]).raw();
        std::memcpy(out.data() + i * sizeof raw, &raw, sizeof raw);
      }
    }
    return out;
  }

  std::vector<double> to_double(const std::vector<std::byte>& bytes) const {
    const std::size_t scalar = plugin::scalar_bytes(precision_);
    std::vector<double> out(bytes.size() / scalar);
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (precision_ == RBDGRAD_PRECISION_F64) {
        std::memcpy(&out[i], bytes.data() + i * sizeof(double), sizeof(double));
      } else if (precision_ == RBDGRAD_PRECISION_F32) {
        float f;
        std::memcpy(&f, bytes.data() + i * sizeof f, sizeof f);
        out[i] = f;
      } else {
        std::int32_t raw;
        std::memcpy(&raw, bytes.data() + i * sizeof raw, sizeof raw);
        out[i] = static_cast<double>(Q16_16::from_raw(raw));
      }
    }
    return out;
  }

  std::uint32_t precision_;
  int nv_;
  std::size_t n_;
  std::vector<std::byte> q_, qd_, tau_, qdd_, dq_, dqd_;
  std::vector<std::int32_t> status_;
};

// compute over the plugin's batch limit in pieces; a per-state failure (state_status) is no error
Status compute_all(server::PluginInstance& instance, std::uint64_t max_batch, TypedBatch& typed, std::size_t n) {
  const std::size_t piece = max_batch == 0 ? n : static_cast<std::size_t>(max_batch);
  for (std::size_t first = 0; first < n; first += piece) {
    const rbdgrad_batch b = typed.batch(first, std::min(piece, n - first));
    const Status s = instance.compute(b);
    if (s) continue;
    bool flagged = false;
    for (std::uint64_t k = 0; k < b.n && !flagged; ++k) flagged = b.state_status[k] != 0;
    if (!flagged) return s;
  }
  return Status::ok();
}

}  // namespace

Status PluginRunner::open(const std::string& path, const Model& model, const std::map<std::string, std::string>& options,
                          std::unique_ptr<PluginRunner>& out) {
  std::unique_ptr<server::Plugin> plugin;
  if (Status s = server::Plugin::load(path, plugin); !s) return s;
  const plugin::ModelDesc desc(model);
  std::unique_ptr<server::PluginInstance> instance;
  if (Status s = plugin->create_instance(desc.desc(), options, instance); !s) return s;
  out.reset(new PluginRunner(std::move(plugin), std::move(instance), model.nv));
  server::InstanceDescription d;
  if (out->instance_->describe(d)) out->mode_ = d.mode;
  return Status::ok();
}

Status PluginRunner::compute(const StateSet& states, std::uint32_t precision, Gradients& out) {
  TypedBatch typed(states, precision);
  if (Status s = compute_all(*instance_, plugin_->info().max_batch, typed, states.n); !s) return s;
  typed.decode(out);
  return Status::ok();
}

Status PluginRunner::time(const StateSet& states, std::uint32_t precision, double min_seconds, double& median_us) {
  using Clock = std::chrono::steady_clock;
  TypedBatch typed(states, precision);
  if (Status s = compute_all(*instance_, plugin_->info().max_batch, typed, states.n); !s) return s;  // warm-up
  std::vector<double> us;
  const Clock::time_point until = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(min_seconds));
  while (us.size() < 3 || Clock::now() < until) {
    const Clock::time_point t0 = Clock::now();
    if (Status s = compute_all(*instance_, plugin_->info().max_batch, typed, states.n); !s) return s;
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  std::nth_element(us.begin(), us.begin() + static_cast<long>(us.size() / 2), us.end());
  median_us = us[us.size() / 2];
  return Status::ok();
}

Status PluginRunner::model_us(std::uint32_t precision, std::uint64_t n, double& us) const {
  return instance_->estimate_latency(precision, RBDGRAD_INPUT_TAU, n, us);
}

}  // namespace rbdgrad::bench
