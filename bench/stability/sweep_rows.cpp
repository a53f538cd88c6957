#include "sweep_rows.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <tuple>

namespace rbdgrad::stability {
namespace {

Row summarize_row(const std::vector<const Sample*>& samples, int precision) {
  Row r;
  r.precision = precision;
  r.error = summarize(samples, precision);
  std::vector<double> cond;
  for (const Sample* s : samples) {
    if (s->outcome[precision].flagged && s->outcome[precision].bad_output) ++r.bad_flagged;
    if (s->reference_ok) cond.push_back(s->cond);
  }
  if (!cond.empty()) {
    std::sort(cond.begin(), cond.end());
    r.median_cond = cond[cond.size() / 2];
    r.max_cond = cond.back();
  }
  return r;
}

void add_rows(std::vector<Row>& rows, const std::string& sweep, const std::string& robot, const std::string& gravity,
              double x, const std::vector<const Sample*>& samples) {
  for (int prec = 0; prec < kNumPrecisions; ++prec) {
    Row r = summarize_row(samples, prec);
    r.sweep = sweep;
    r.robot = robot;
    r.gravity = gravity;
    r.x = x;
    rows.push_back(std::move(r));
  }
}

}  // namespace

std::vector<Row> make_rows(const std::vector<Point>& points) {
  std::vector<Row> rows;
  std::map<std::tuple<std::string, double>, std::vector<const Sample*>> pooled;  // (sweep, x)
  std::map<int, std::vector<const Sample*>> by_cond;                           // decade of cond(M)
  for (const Point& p : points) {
    std::vector<const Sample*> samples;
    for (const Sample& s : p.samples) {
      samples.push_back(&s);
      if (p.spec.sweep != "velocity" && s.reference_ok && std::isfinite(s.cond))
        by_cond[static_cast<int>(std::floor(std::log10(s.cond)))].push_back(&s);
    }
    add_rows(rows, p.spec.sweep, p.spec.robot, p.spec.gravity ? "on" : "off", p.spec.x, samples);
    auto& pool = pooled[{p.spec.sweep, p.spec.x}];
    pool.insert(pool.end(), samples.begin(), samples.end());
  }
  for (const auto& [key, samples] : pooled) add_rows(rows, std::get<0>(key), "all", "both", std::get<1>(key), samples);
  for (const auto& [decade, samples] : by_cond) add_rows(rows, "cond", "all", "both", std::pow(10.0, decade + 1), samples);
  return rows;
}

void write_csv(std::ostream& out, const std::vector<Row>& rows) {
  out << "sweep,robot,gravity,x,precision,states,measured,median_err_dqdd_dq,worst_err_dqdd_dq,median_err_dqdd_dqd,"
         "worst_err_dqdd_dqd,flagged,nonfinite_flagged,nonfinite_unflagged,median_cond,max_cond\n";
  out.precision(6);
  for (const Row& r : rows) {
    const ErrorSummary& e = r.error;
    out << r.sweep << ',' << r.robot << ',' << r.gravity << ',' << r.x << ',' << kPrecisionNames[r.precision] << ','
        << e.states << ',' << e.measured << ',' << e.median_dq << ',' << e.worst_dq << ',' << e.median_dqd << ','
        << e.worst_dqd << ',' << e.flagged << ',' << r.bad_flagged << ',' << e.silent_failures << ',' << r.median_cond
        << ',' << r.max_cond << '\n';
  }
}

}  // namespace rbdgrad::stability
