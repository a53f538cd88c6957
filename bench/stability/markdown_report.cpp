#include "markdown_report.hpp"

#include <cstdio>
#include <map>
#include <ostream>
#include <set>
#include <string>

#include "trust_region.hpp"

namespace rbdgrad::stability {
namespace {

// What x is in each sweep, in the order the report lists them.
struct SweepInfo {
  const char* name;
  const char* x;
};
constexpr SweepInfo kSweeps[] = {
    {"velocity", "max joint speed max_i |q̇_i| (rad/s)"},
    {"mass_ratio", "tip/root ratio of link mass and inertia"},
    {"inertia_ratio", "tip/root ratio of link rotational inertia (mass kept)"},
    {"joint_limit", "distance of every joint from a limit (fraction of its range; 0 = at the limit)"},
    {"singularity", "size of the perturbation of q = 0 (rad; iiwa14 stretched out, axes 1, 3, 5, 7 in line)"},
    {"joints", "number of joints of random chains and trees"},
    {"cond", "cond(M), upper end of a decade (states of every sweep but velocity, pooled)"},
};

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1e", v);
  return buf;
}

// "3.7e-14 / 1.3e-13", with the share of flagged and of wrong-but-unflagged states when any
std::string cell(const Row& r) {
  const ErrorSummary& e = r.error;
  std::string s = e.measured > 0 ? sci(e.median()) + " / " + sci(e.worst()) : "-";
  char buf[64];
  if (e.flagged > 0) {
    std::snprintf(buf, sizeof buf, ", %d%% flagged", (100 * e.flagged + e.states / 2) / e.states);
    s += buf;
  }
  if (e.wrong > 0) {
    std::snprintf(buf, sizeof buf, ", %d wrong > 100%%", e.wrong);
    s += buf;
  }
  return s;
}

void region_table(std::ostream& out, const std::vector<Row>& rows) {
  const std::vector<Criterion>& criteria = trust_criteria();
  out << "| sweep | robot |";
  for (const Criterion& c : criteria) out << ' ' << c.label() << " |";
  out << "\n|---|---|";
  for (size_t k = 0; k < criteria.size(); ++k) out << "---|";
  out << '\n';
  for (const SweepInfo& sweep : kSweeps) {
    // per robot: a pooled median would hide a robot that fails (only cond(M) is pooled)
    std::set<std::string> robots;
    for (const Row& r : rows)
      if (r.sweep == sweep.name && (r.robot != "all" || !flags_disqualify(r.sweep))) robots.insert(r.robot);
    for (const std::string& robot : robots) {
      out << "| " << sweep.name << " | " << robot << " |";
      for (const Criterion& c : criteria) out << ' ' << describe(trust_region(rows, sweep.name, robot, c)) << " |";
      out << '\n';
    }
  }
}

// One sentence per robot and criterion for the speed sweep, one per criterion for cond(M).
void statements(std::ostream& out, const std::vector<Row>& rows) {
  std::set<std::string> robots;
  for (const Row& r : rows)
    if (r.sweep == "velocity" && r.robot != "all") robots.insert(r.robot);
  for (const Criterion& c : trust_criteria()) {
    for (const std::string& robot : robots) {
      const Region reg = trust_region(rows, "velocity", robot, c);
      out << "- " << c.label() << " on " << robot << ", no state flagged: ";
      if (reg.run == 0) out << "at no swept speed\n";
      else out << "while " << sci(reg.lo) << " <= max |q̇_i| <= " << sci(reg.hi) << " rad/s" << (reg.run == reg.points ? " (the whole sweep)" : "") << '\n';
    }
    const Region reg = trust_region(rows, "cond", "all", c);
    out << "- " << c.label() << ", every robot and sweep at 1 rad/s (flagged states left out): ";
    if (reg.run == 0) out << "in no decade of cond(M)\n";
    else out << "while " << sci(reg.lo / 10) << " <= cond(M) < " << sci(reg.hi) << '\n';
  }
}

// The worst f64 result of any robot and grid point, where it was, and how large cond(M) got there.
void worst_f64(std::ostream& out, const std::vector<Row>& rows) {
  const Row* worst = nullptr;
  for (const Row& r : rows)
    if (r.precision == 0 && r.robot != "all" && r.error.measured > 0 && (!worst || r.error.worst() > worst->error.worst()))
      worst = &r;
  if (!worst) return;
  out << "- f64 worst of all: " << sci(worst->error.worst()) << " (" << worst->sweep << ", " << worst->robot
      << ", x = " << sci(worst->x) << ", gravity " << worst->gravity << ", cond(M) up to " << sci(worst->max_cond)
      << ")\n";
}

void growth_tables(std::ostream& out, const std::vector<Row>& rows) {
  for (const SweepInfo& sweep : kSweeps) {
    std::map<double, const Row*> by_x[kNumPrecisions];
    for (const Row& r : rows)
      if (r.sweep == sweep.name && r.robot == "all") by_x[r.precision][r.x] = &r;
    if (by_x[0].empty()) continue;
    out << "\n**" << sweep.name << "**: x = " << sweep.x << "\n\n| x |";
    for (const char* p : kPrecisionNames) out << ' ' << p << " |";
    out << " cond(M) median |\n|---|";
    for (int p = 0; p < kNumPrecisions; ++p) out << "---|";
    out << "---|\n";
    for (const auto& [x, row] : by_x[0]) {
      out << "| " << sci(x) << " |";
      for (int p = 0; p < kNumPrecisions; ++p) out << ' ' << cell(*by_x[p].at(x)) << " |";
      out << ' ' << sci(row->median_cond) << " |\n";
    }
  }
}

}  // namespace

void write_markdown(std::ostream& out, const std::vector<Row>& rows, const ReportInfo& info) {
  out << "### Numerical stability sweeps\n\n"
      << "Generated by `stability_sweep` (bench/stability) in " << static_cast<int>(info.seconds + 0.5) << " s: "
      << info.states_per_point << " random states per grid point and gravity setting, every precision run through "
      << "`fd_derivatives` (tau input) and compared with the same computation in long double (64-bit mantissa). "
      << "Error: the relative Frobenius error of dqdd/dq and of dqdd/dqd, the larger of the two, over the states "
      << "that were not flagged (for an output that is zero in exact arithmetic, the absolute error). Joints move at 1 rad/s "
      << "(or m/s) wherever speed is not swept; torques give |qdd_i| <= 1.\n\n"
      << "Silent failures (a NaN, Inf or saturated fixed-point value handed on without a non-ok Status or "
      << "overflow flag): **" << info.silent_failures << "** of " << info.results << " results.\n\n"
      << "A grid point is trustworthy for a precision when its error statistic is within the bound in the "
      << "column heading, no state there was flagged (fixed-point overflow, NaN/Inf, mass matrix not positive "
      << "definite) nor wrong by more than 100% without a flag, with gravity on and with gravity off. The "
      << "region is the longest run of consecutive trustworthy grid points. The cond(M) bins pool every robot; "
      << "there a flagged state is left out instead (overflow depends on magnitudes, not on conditioning).\n\n"
      << "#### Trustworthy region per precision and robot\n\n";
  region_table(out, rows);
  out << "\n#### In words\n\n";
  statements(out, rows);
  worst_f64(out, rows);
  out << "\n#### Error growth (median / worst relative error; all robots and both gravity settings pooled)\n";
  growth_tables(out, rows);
}

}  // namespace rbdgrad::stability
