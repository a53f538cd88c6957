// The FPGA kernel's arithmetic (plugins/fpga/kernel/gradient_kernel.hpp, the code HLS synthesizes)
// run on the host in fixed-point formats other than the bitstream's Q16.16, to see what a wider or
// differently split word would buy. The host's part is the FPGA plugin's: M^-1(q) in double from
// the core library, sin and cos of q in double, each rounded once into the format. Every state runs
// under a FixedOverflowScope: one that overflowed is flagged, never compared silently.
#pragma once

#include <string>
#include <vector>

#include "accuracy_states.hpp"
#include "gradients.hpp"

namespace rbdgrad::bench {

/// A Fixed<total_bits, frac_bits> format the benchmark is built for: "Q16.16" is 32 bits with 16
/// fractional ones.
struct FixedFormat {
  std::string name;
  int total_bits = 0;
  int frac_bits = 0;
};

/// The formats compiled in: Q20.12, Q16.16 (the bitstream's), Q12.20 (32 bits each), Q24.24 (48).
const std::vector<FixedFormat>& fixed_formats();

/// Runs every state of `states` through the kernel in `format` (one of fixed_formats()): fills
/// out's gradients, q̈ and the M⁻¹ the kernel was given (each as rounded into the format, zero for
/// a flagged state) and state_status (1 = overflowed, or M⁻¹ failed). Also used by trajopt_bench.
/// Errors: invalid_argument for a format not compiled in or a model above the kernel's 32 joints.
Status run_fixed_format(const FixedFormat& format, const Model& model, const StateSet& states, Gradients& out);

}  // namespace rbdgrad::bench
