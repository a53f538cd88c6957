#include "test_points.hpp"

#include <cstdio>
#include <sstream>

namespace rbdgrad::stability {

SweepGrid test_grid() {
  SweepGrid g;
  g.states_per_point = 6;
  g.speed_points_per_decade = 1;
  g.ratio_points_per_decade = 1;
  g.robots = {"iiwa14", "chain64", "tree64"};
  g.joint_counts = {1, 4, 16, 64};
  g.models_per_count = 2;
  g.limit_fractions = {0, 1e-3, 0.1, 0.5};
  g.singularity_offsets = {0, 1e-6, 1e-3, 1};
  return g;
}

const std::vector<Point>& test_points() {
  static const std::vector<Point> points = [] {
    const SweepGrid g = test_grid();
    const std::vector<PointSpec> plan = stability_plan(g);
    std::vector<Point> out;
    for (size_t i = 0; i < plan.size(); ++i) out.push_back(run_point(plan[i], g.states_per_point, static_cast<unsigned>(i + 1)));
    return out;
  }();
  return points;
}

std::string describe(const PointSpec& p) {
  std::ostringstream s;
  s << p.sweep << " " << p.robot << " x=" << p.x << " gravity " << (p.gravity ? "on" : "off");
  return s.str();
}

}  // namespace rbdgrad::stability
