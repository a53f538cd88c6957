#include "trust_region.hpp"

#include <cmath>
#include <cstdio>
#include <map>

namespace rbdgrad::stability {

std::string Criterion::label() const {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s %s <= %.0e", kPrecisionNames[precision], worst ? "worst" : "median", bound);
  return buf;
}

const std::vector<Criterion>& trust_criteria() {
  static const std::vector<Criterion> criteria = {
      {0, true, 1e-8}, {1, false, 1e-4}, {1, false, 1e-3}, {2, false, 1e-2}, {2, false, 5e-2}};
  return criteria;
}

bool flags_disqualify(const std::string& sweep) { return sweep != "cond"; }

bool trustworthy(const Row& r, const Criterion& c) {
  const ErrorSummary& e = r.error;
  const double stat = c.worst ? e.worst() : e.median();
  const bool flags_ok = e.flagged == 0 || !flags_disqualify(r.sweep);
  // a NaN statistic (nothing measured) fails the comparison
  return r.precision == c.precision && flags_ok && e.silent_failures == 0 && e.wrong == 0 && stat <= c.bound;
}

Region trust_region(const std::vector<Row>& rows, const std::string& sweep, const std::string& robot,
                    const Criterion& c) {
  std::map<double, bool> pass;  // x -> trustworthy at every gravity setting
  for (const Row& r : rows) {
    if (r.sweep != sweep || r.robot != robot || r.precision != c.precision) continue;
    auto [it, inserted] = pass.emplace(r.x, true);
    it->second = it->second && trustworthy(r, c);
  }
  Region region;
  region.points = static_cast<int>(pass.size());
  int run = 0;
  double start = 0;
  for (const auto& [x, ok] : pass) {
    if (!ok) {
      run = 0;
      continue;
    }
    ++region.passing;
    if (run++ == 0) start = x;
    if (run > region.run) {
      region.run = run;
      region.lo = start;
      region.hi = x;
    }
  }
  return region;
}

std::string describe(const Region& r) {
  char buf[96];
  if (r.run == 0) {
    std::snprintf(buf, sizeof buf, "none of %d", r.points);
  } else if (r.run == r.points) {
    std::snprintf(buf, sizeof buf, "%.3g - %.3g (all %d)", r.lo, r.hi, r.points);
  } else if (r.passing == r.run) {
    std::snprintf(buf, sizeof buf, "%.3g - %.3g (%d of %d)", r.lo, r.hi, r.run, r.points);
  } else {  // trustworthy points outside the run too: not a region, but said
    std::snprintf(buf, sizeof buf, "%.3g - %.3g (%d of %d; %d in all)", r.lo, r.hi, r.run, r.points, r.passing);
  }
  return buf;
}

}  // namespace rbdgrad::stability
