// CSV and Markdown of the runs: see run_report.hpp.
#include "run_report.hpp"

#include <cstdio>
#include <ostream>

namespace rbdgrad::trajopt {

namespace {

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string sci(double v) { return format("%.2e", v); }

const char* outcome_name(RunRecord::Outcome o) {
  switch (o) {
    case RunRecord::Outcome::kDone: return "done";
    case RunRecord::Outcome::kOverflowed: return "overflowed";
    case RunRecord::Outcome::kFailed: return "failed";
    case RunRecord::Outcome::kSkipped: return "skipped";
  }
  return "?";
}

// whether the run has numbers: it optimized, to the end or until an overflow stopped it
bool has_numbers(const RunRecord& r) {
  return r.outcome == RunRecord::Outcome::kDone || r.outcome == RunRecord::Outcome::kOverflowed;
}

// CSV field: quoted when it holds a comma, quote or newline
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string run_name(const RunRecord& r) {
  // a backend that was not ready has no precision ("-")
  const std::string precision = r.precision == "-" ? "" : " " + r.precision;
  return r.backend + precision + (r.mode.empty() ? "" : " (" + r.mode + ")");
}

}  // namespace

void write_csv(std::ostream& out, const std::vector<RunRecord>& runs) {
  out << "backend,precision,mode,outcome,reason,iterations,gradient_calls,converged,initial_cost,final_cost,"
         "q_error_rad,qd_error_rad_s,initial_q_error_rad,reached_goal,wall_s,gradient_s,server_compute_s,"
         "max_grad_rel_error,max_minv_rel_error,fallback_states,max_tau_over_limit,max_qd_over_limit,"
         "within_position_limits,overflowed_states\n";
  for (const RunRecord& r : runs) {
    out << r.backend << ',' << r.precision << ',' << r.mode << ',' << outcome_name(r.outcome) << ','
        << csv_field(r.reason);
    if (!has_numbers(r)) {
      out << std::string(19, ',') << '\n';
      continue;
    }
    out << ',' << r.iterations << ',' << r.gradient_calls << ',' << (r.converged ? "true" : "false") << ','
        << format("%.9g", r.initial_cost) << ',' << format("%.9g", r.final_cost) << ',' << format("%.6g", r.q_error)
        << ',' << format("%.6g", r.qd_error) << ',' << format("%.6g", r.initial_q_error) << ','
        << (r.reached ? "true" : "false") << ',' << format("%.4f", r.wall_s) << ',' << format("%.4f", r.gradient_s)
        << ',' << format("%.4f", r.server_compute_s) << ',' << format("%.3e", r.max_grad_error) << ','
        << format("%.3e", r.max_minv_error) << ',' << r.fallback_states << ',' << format("%.3f", r.max_tau_ratio)
        << ',' << format("%.3f", r.max_qd_ratio) << ',' << (r.within_position_limits ? "true" : "false") << ','
        << r.overflowed_states << '\n';
  }
}

void write_markdown(std::ostream& out, const ReachTask& task, const std::string& context,
                    const std::vector<RunRecord>& runs) {
  out << "iLQR on iiwa14, " << task.horizon << " steps of " << task.dt * 1e3
      << " ms, rollouts in f64 in-process, gradients from rbdgradd or, for fpga kernel (host), from the FPGA kernel's "
         "arithmetic in-process in each fixed-point format; goal reached when ‖q_T − q_goal‖ < "
      << format("%g", task.goal_q_tol) << " rad and ‖q̇_T‖ < " << format("%g", task.goal_qd_tol) << " rad/s. "
      << "Errors: the worst state's relative Frobenius error of [∂q̈/∂q ∂q̈/∂q̇] and of M⁻¹ against the core library's "
         "f64 at the same states. "
      << context << "\n\n"
      << "| backend | precision | iterations | converged | final cost | ‖q_T − q_goal‖ rad | ‖q̇_T‖ rad/s | goal "
         "reached | wall s | gradient calls s | max gradient error | max M⁻¹ error | fallback states | overflowed states "
         "|\n"
      << "|---|---|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|\n";
  for (const RunRecord& r : runs) {
    const std::string precision = r.precision + (r.mode.empty() ? "" : " (" + r.mode + ")");
    if (!has_numbers(r)) {
      out << "| " << r.backend << " | " << precision << " | " << outcome_name(r.outcome)
          << " | | | | | | | | | | | |\n";
      continue;
    }
    out << "| " << r.backend << " | " << precision << " | " << r.iterations << " | " << (r.converged ? "yes" : "no")
        << " | " << format("%.8g", r.final_cost) << " | " << sci(r.q_error) << " | " << sci(r.qd_error) << " | "
        << (r.reached ? "yes" : "**no**") << " | " << format("%.3f", r.wall_s) << " | "
        << format("%.3f", r.gradient_s) << " | " << sci(r.max_grad_error) << " | " << sci(r.max_minv_error) << " | "
        << r.fallback_states << " | " << r.overflowed_states << " |\n";
  }
  out << "\n";
  for (const RunRecord& r : runs) {
    out << "- " << run_name(r) << ": ";
    switch (r.outcome) {
      case RunRecord::Outcome::kSkipped: out << "not run: " << r.reason << ".\n"; continue;
      case RunRecord::Outcome::kFailed: out << "FAILED: " << r.reason << ".\n"; continue;
      case RunRecord::Outcome::kDone:
      case RunRecord::Outcome::kOverflowed: break;
    }
    out << (r.reached ? "reached the goal" : "did NOT reach the goal") << " (‖q_T − q_goal‖ = " << sci(r.q_error)
        << " rad, ‖q̇_T‖ = " << sci(r.qd_error) << " rad/s) after " << r.iterations << " iterations; "
        << (r.converged ? "converged" : "stopped: " + r.reason) << "; cost " << format("%.6g", r.initial_cost)
        << " → " << format("%.8g", r.final_cost) << "; errors up to " << sci(r.max_grad_error) << " (gradient), "
        << sci(r.max_minv_error) << " (M⁻¹)";
    if (r.fallback_states) out << "; " << r.fallback_states << " states left Q16.16 and were computed in f64";
    if (r.outcome == RunRecord::Outcome::kOverflowed)
      out << "; the run stops at an overflow rather than put f64 derivatives in the flagged states' place";
    out << ".\n";
  }
}

}  // namespace rbdgrad::trajopt
