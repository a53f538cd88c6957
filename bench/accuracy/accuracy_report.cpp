#include "accuracy_report.hpp"

#include <cmath>
#include <cstdio>

namespace rbdgrad::bench {
namespace {

// 3 significant digits, or "-" for NaN (nothing measured)
std::string num(double x) {
  if (std::isnan(x)) return "-";
  char text[32];
  if (x != 0 && (std::fabs(x) < 1e-3 || std::fabs(x) >= 1e5)) std::snprintf(text, sizeof text, "%.2e", x);
  else std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

// full precision for the CSV; empty for NaN
std::string csv_num(double x) {
  if (std::isnan(x)) return "";
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", x);
  return text;
}

std::string pair(const ErrorSummary& e) { return num(e.median) + " / " + num(e.worst); }

}  // namespace

void write_csv(std::ostream& os, const std::vector<AccuracyRow>& rows) {
  os << "robot,nv,backend,mode,precision,timing,n,us_per_state,"
        "ref_dq_median,ref_dq_worst,ref_dqd_median,ref_dqd_worst,ref_states,ref_flagged,"
        "f64_dq_median,f64_dq_worst,f64_dqd_median,f64_dqd_worst,f64_states,f64_flagged,unflagged_nonfinite\n";
  for (const AccuracyRow& r : rows) {
    const GradientErrors& f = r.vs_f64;
    const auto f64 = [&](double x) { return r.has_vs_f64 ? csv_num(x) : std::string(); };
    for (const auto& [n, us] : r.us_per_state) {
      os << r.robot << ',' << r.nv << ',' << r.backend << ',' << r.mode << ',' << r.precision << ',' << r.timing << ','
         << n << ',' << csv_num(us) << ',' << csv_num(r.vs_reference.dqdd_dq.median) << ','
         << csv_num(r.vs_reference.dqdd_dq.worst) << ',' << csv_num(r.vs_reference.dqdd_dqd.median) << ','
         << csv_num(r.vs_reference.dqdd_dqd.worst) << ',' << r.vs_reference.states << ',' << r.vs_reference.flagged
         << ',' << f64(f.dqdd_dq.median) << ',' << f64(f.dqdd_dq.worst) << ',' << f64(f.dqdd_dqd.median) << ','
         << f64(f.dqdd_dqd.worst) << ',' << (r.has_vs_f64 ? std::to_string(f.states) : "") << ','
         << (r.has_vs_f64 ? std::to_string(f.flagged) : "") << ','
         << r.vs_reference.unflagged_nonfinite + f.unflagged_nonfinite << '\n';
    }
  }
}

void write_markdown(std::ostream& os, const std::vector<AccuracyRow>& rows, const std::vector<std::uint64_t>& sizes) {
  std::string robot;
  for (const AccuracyRow& r : rows) {
    if (r.robot != robot) {
      robot = r.robot;
      os << "\n#### " << r.robot << " (nv = " << r.nv << ")\n\n"
         << "Time per state (µs) at each N; relative Frobenius error, median / worst over the states compared "
            "(flagged states are left out and counted: of the Pinocchio states, of the random ones).\n\n| backend | precision | timing |";
      for (std::uint64_t n : sizes) os << " N = " << n << " |";
      os << " ∂q̈/∂q vs Pinocchio | ∂q̈/∂q̇ vs Pinocchio | ∂q̈/∂q vs f64 | ∂q̈/∂q̇ vs f64 | flagged |\n|---|---|---|";
      for (std::size_t i = 0; i < sizes.size(); ++i) os << "---:|";
      os << "---|---|---|---|---:|\n";
    }
    os << "| " << r.backend << (r.mode.empty() ? "" : " (" + r.mode + ")") << " | " << r.precision << " | " << r.timing
       << " |";
    for (std::uint64_t n : sizes) {
      double us = std::nan("");
      for (const auto& [m, t] : r.us_per_state)
        if (m == n) us = t;
      os << ' ' << num(us) << " |";
    }
    os << ' ' << pair(r.vs_reference.dqdd_dq) << " | " << pair(r.vs_reference.dqdd_dqd) << " | "
       << (r.has_vs_f64 ? pair(r.vs_f64.dqdd_dq) : "(the f64 result)") << " | "
       << (r.has_vs_f64 ? pair(r.vs_f64.dqdd_dqd) : "") << " | " << r.vs_reference.flagged << "/"
       << r.vs_reference.flagged + r.vs_reference.states + r.vs_reference.unflagged_nonfinite;
    if (r.has_vs_f64)
      os << ", " << r.vs_f64.flagged << "/" << r.vs_f64.flagged + r.vs_f64.states + r.vs_f64.unflagged_nonfinite;
    os << " |\n";
  }
}

}  // namespace rbdgrad::bench
