// The benchmarks' workload for the host-side tools that run the CUDA block kernel's device code
// as plain C++ (cuda_flop_count, cuda_shared_wavefronts): `states` random states of a model from
// tau, outputs d qdd/d q and d qdd/d qd, held in vectors of the tool's scalar type S.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "device/block_fused_state.hpp"

namespace rbdgrad::cuda {

template <class S>
struct GradientWorkload {
  std::vector<S> q, qd, tau, dq, dqd;
  std::vector<std::uint32_t> status;
  BatchPointers<S> batch;

  // inputs uniform in [-1, 1] from `seed`
  GradientWorkload(int nv, std::size_t states, unsigned seed)
      : q(states * static_cast<std::size_t>(nv)),
        qd(q.size()),
        tau(q.size()),
        dq(q.size() * static_cast<std::size_t>(nv)),
        dqd(dq.size()),
        status(states) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uniform(-1, 1);
    for (auto* x : {&q, &qd, &tau})
      for (S& e : *x) e = S(uniform(rng));
    batch.n = static_cast<decltype(batch.n)>(states);
    batch.outputs = kOutputDqddDq | kOutputDqddDqd;
    batch.tau_input = true;
    batch.q = q.data();
    batch.qd = qd.data();
    batch.u = tau.data();
    batch.out[output_index(kOutputDqddDq)] = dq.data();
    batch.out[output_index(kOutputDqddDqd)] = dqd.data();
    batch.status = status.data();
  }
  // the pointers refer to this object's vectors
  GradientWorkload(const GradientWorkload&) = delete;
  GradientWorkload& operator=(const GradientWorkload&) = delete;

  // how many states failed (a nonzero status)
  std::size_t failed() const {
    std::size_t k = 0;
    for (std::uint32_t s : status) k += s != 0;
    return k;
  }
};

}  // namespace rbdgrad::cuda
