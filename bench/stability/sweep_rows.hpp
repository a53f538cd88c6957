// The sweeps' results as rows, one per sweep, point, robot and precision (the CSV's rows): per
// robot and gravity setting, pooled over robots and gravity ("all", "both"), and rebinned by
// cond(M) (sweep "cond").
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "stability_sweeps.hpp"

namespace rbdgrad::stability {

struct Row {
  std::string sweep, robot;
  std::string gravity;  // "on", "off" or "both" (pooled)
  double x = 0;         // the swept quantity; for sweep "cond", the upper end of a decade of cond(M)
  int precision = 0;    // index into kPrecisionNames
  ErrorSummary error;
  int bad_flagged = 0;  // flagged states whose outputs hold a NaN, Inf or saturated value
  double median_cond = 0, max_cond = 0;
};

// Pooled rows carry robot "all"; the cond bins pool the states of every sweep run at the nominal
// speed (all but "velocity", so that speed does not mix into the error against cond(M)).
std::vector<Row> make_rows(const std::vector<Point>& points);

void write_csv(std::ostream& out, const std::vector<Row>& rows);

}  // namespace rbdgrad::stability
