// The linearization of a whole trajectory from the FPGA kernel's arithmetic run in-process in one
// fixed-point format (bench/accuracy/fixed_format_kernel.hpp: Q20.12, Q16.16, Q12.20, Q24.24), no
// daemon: the same Linearization and statistics as DaemonLinearizer, for the formats the daemon
// does not serve. A state the kernel flags (an overflow in the format) has no honest derivatives:
// the call fails and says so, and nothing is computed again in f64 in its place — unlike the
// daemon's fixed point, which falls back per state.
#pragma once

#include <string>

#include "arm_plant.hpp"
#include "fixed_format_kernel.hpp"
#include "ilqr.hpp"
#include "linearizer_stats.hpp"

namespace rbdgrad::trajopt {

class KernelLinearizer {
 public:
  /// `format` is one of bench::fixed_formats(); `reference` computes the f64 derivatives for the
  /// error measurement (its own workspace, not the plant's) and gives the model.
  KernelLinearizer(bench::FixedFormat format, ArmPlant& reference);

  /// Fills `out` for every step of `t`; returns "" or the problem: the kernel's error, or
  /// "state k of iteration i overflowed in FORMAT (m of N states flagged)", after which
  /// overflowed() is true.
  std::string operator()(const Trajectory& t, Linearization& out);

  const LinearizerStats& stats() const { return stats_; }
  bool overflowed() const { return stats_.overflowed_states > 0; }

 private:
  bench::FixedFormat format_;
  ArmPlant& reference_;
  bench::StateSet states_;
  bench::Gradients result_;
  LinearizerStats stats_;
};

}  // namespace rbdgrad::trajopt
