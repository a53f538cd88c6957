// The Markdown fragment of the sweeps: the thresholds, the trustworthy region per precision and
// robot, and the error growth per precision, all computed from the rows.
#pragma once

#include <iosfwd>
#include <vector>

#include "sweep_rows.hpp"

namespace rbdgrad::stability {

struct ReportInfo {
  int states_per_point = 0;
  long results = 0;  // states x precisions
  long silent_failures = 0;
  double seconds = 0;
};

void write_markdown(std::ostream& out, const std::vector<Row>& rows, const ReportInfo& info);

}  // namespace rbdgrad::stability
