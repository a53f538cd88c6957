#include "coalescer.hpp"

#include <cstring>
#include <utility>

#include "common/batch_view.hpp"
#include "compute_call.hpp"

namespace rbdgrad::server {

namespace {

// One backend call for a group: the members' inputs end to end, the outputs likewise; on its run
// each member takes its slice and completes (or computes again alone, see Coalescer).
class GroupJob : public PoolJob {
 public:
  GroupJob(std::vector<ComputeCall*> calls, std::uint64_t states) : calls_(std::move(calls)), states_(states) {}

  void run(PluginInstance& instance) noexcept override {
    rbdgrad_batch b{};
    Status status = Status::ok();
    try {
      b = gather();
    } catch (const std::exception& e) {
      status = Status(StatusCode::kInternal, std::string("batching: ") + e.what());
    }
    const auto started = Coalescer::Clock::now();
    if (status) status = instance.compute(b);
    const auto compute = Coalescer::Clock::now() - started;
    // a failure of some states leaves the others computed (plugin_api.h); a failure of the whole
    // call (a lost device) leaves none, whatever state_status says
    bool some_states_failed = false;
    for (std::int32_t s : status_) some_states_failed |= s != 0;
    if (!status && !some_states_failed) status_.assign(states_, RBDGRAD_ERROR_INTERNAL);
    std::uint64_t first = 0;
    for (ComputeCall* call : calls_) {
      const std::uint64_t n = call->prepared_batch().n;
      // the call may be gone after this
      call->finish_in_group(instance, b, first, started, compute, calls_.size(), first == 0 ? states_ : 0);
      first += n;
    }
    delete this;
  }

 private:
  // the members' inputs end to end, and room for the outputs
  rbdgrad_batch gather() {
    const rbdgrad_batch& t = calls_.front()->prepared_batch();
    const std::size_t nv = static_cast<std::size_t>(calls_.front()->nv()), s = plugin::scalar_bytes(t.precision);
    const std::size_t vec = nv * s;
    rbdgrad_batch b = t;
    b.n = states_;
    auto join = [&](const void* rbdgrad_batch::*field, std::size_t per_state, std::vector<std::byte>& to) -> const void* {
      if (t.*field == nullptr) return nullptr;
      to.resize(states_ * per_state);
      std::size_t at = 0;
      for (ComputeCall* c : calls_) {
        const rbdgrad_batch& cb = c->prepared_batch();
        std::memcpy(to.data() + at, cb.*field, cb.n * per_state);
        at += cb.n * per_state;
      }
      return to.data();
    };
    b.q = join(&rbdgrad_batch::q, vec, q_);
    b.qd = join(&rbdgrad_batch::qd, vec, qd_);
    b.u = join(&rbdgrad_batch::u, vec, u_);
    b.minv = join(&rbdgrad_batch::minv, vec * nv, minv_);
    b.fext = join(&rbdgrad_batch::fext, 6 * vec, fext_);
    void** outputs[] = {&b.qdd, &b.minv_out, &b.dqdd_dq, &b.dqdd_dqd, &b.tau, &b.dtau_dq, &b.dtau_dqd, &b.m};
    for (int o = 0; o < 8; ++o) {
      *outputs[o] = nullptr;
      if ((b.outputs & (1u << o)) == 0) continue;
      out_[o].resize(states_ * ((b.outputs & (1u << o) & plugin::kMatrixOutputs) ? vec * nv : vec));
      *outputs[o] = out_[o].data();
    }
    status_.assign(states_, 0);
    b.state_status = status_.data();
    return b;
  }

  std::vector<ComputeCall*> calls_;
  const std::uint64_t states_;
  std::vector<std::byte> q_, qd_, u_, minv_, fext_, out_[8];
  std::vector<std::int32_t> status_;
};

}  // namespace

Coalescer::Coalescer(std::chrono::microseconds max_delay, std::uint64_t preferred_states)
    : max_delay_(max_delay), preferred_(preferred_states), timer_(&Coalescer::timer_loop, this) {}

Coalescer::~Coalescer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  timer_.join();
}

bool Coalescer::takes(const ComputeCall& call) const {
  const rbdgrad_batch& b = call.prepared_batch();
  return b.n < preferred_ && b.precision != RBDGRAD_PRECISION_FIXED_Q16_16;
}

void Coalescer::add(ComputeCall& call) {
  const rbdgrad_batch& b = call.prepared_batch();
  const Key key{call.pool(), b.precision, b.input_kind, b.outputs, b.minv != nullptr, b.fext != nullptr};
  std::vector<ComputeCall*> full;
  std::uint64_t states = 0;
  bool first = false;
  {
    std::lock_guard lock(mutex_);
    Group& g = groups_[key];
    first = g.calls.empty();
    if (first) g.due = Clock::now() + max_delay_;
    g.calls.push_back(&call);
    g.states += b.n;
    if (g.states >= preferred_) {
      full = std::move(g.calls);
      states = g.states;
      groups_.erase(key);
    }
  }
  if (!full.empty()) {
    send(std::get<0>(key), std::move(full), states);
  } else if (first) {
    changed_.notify_all();  // a new deadline for the timer
  }
}

void Coalescer::send(InstancePool* pool, std::vector<ComputeCall*> calls, std::uint64_t states) {
  double predicted = 0;
  for (const ComputeCall* c : calls) predicted += c->predicted_us();
  auto* job = new GroupJob(std::move(calls), states);  // deletes itself at the end of its run
  pool->submit(*job, states, predicted);
}

void Coalescer::timer_loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    // the groups that are due (all of them when stopping) go out, outside the lock
    const Clock::time_point now = Clock::now();
    std::vector<std::tuple<InstancePool*, std::vector<ComputeCall*>, std::uint64_t>> due;
    Clock::time_point next = Clock::time_point::max();
    for (auto it = groups_.begin(); it != groups_.end();) {
      if (stop_ || it->second.due <= now) {
        due.emplace_back(std::get<0>(it->first), std::move(it->second.calls), it->second.states);
        it = groups_.erase(it);
      } else {
        next = std::min(next, it->second.due);
        ++it;
      }
    }
    if (!due.empty()) {
      lock.unlock();
      for (auto& [pool, calls, states] : due) send(pool, std::move(calls), states);
      lock.lock();
      continue;
    }
    if (stop_) return;
    if (next == Clock::time_point::max()) {
      changed_.wait(lock);
    } else {
      changed_.wait_until(lock, next);
    }
  }
}

}  // namespace rbdgrad::server
