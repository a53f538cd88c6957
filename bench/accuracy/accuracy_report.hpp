// The accuracy benchmark's results: one row per robot, backend and precision, with its time per
// state at each N and its errors; written as CSV (one line per N, for the plot script) and as
// Markdown tables (one per robot, for docs/benchmarks/accuracy.md).
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "error_summary.hpp"

namespace rbdgrad::bench {

struct AccuracyRow {
  std::string robot;
  int nv = 0;
  std::string backend;    // "cpu", "cuda", "fpga"; "fpga kernel" for the in-process formats
  std::string mode;       // "csim" for the FPGA kernel's C simulation, else ""
  std::string precision;  // "f64", "f32", "Q16.16", ...
  std::string timing;     // how the times were obtained: "measured", "cycle model", ...
  std::vector<std::pair<std::uint64_t, double>> us_per_state;  // (N, microseconds per state)
  GradientErrors vs_reference;  // against Pinocchio's float64 values
  GradientErrors vs_f64;        // against the CPU plugin's f64 result on random states
  bool has_vs_f64 = true;       // false for that f64 result itself
};

void write_csv(std::ostream& os, const std::vector<AccuracyRow>& rows);

/// A table per robot: time per state at each N, then the median / worst relative errors.
/// `sizes` are the table's columns.
void write_markdown(std::ostream& os, const std::vector<AccuracyRow>& rows, const std::vector<std::uint64_t>& sizes);

}  // namespace rbdgrad::bench
