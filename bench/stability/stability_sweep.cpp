// The long numerical-stability sweeps (issue 7): every sweep of tests/stability on a finer grid,
// more states per point and more robots; writes a CSV (one row per sweep, point, robot and
// precision) and a Markdown fragment with the trustworthy region of each precision.
//
//   stability_sweep --csv stability.csv --markdown stability.md [--quick]
//
// Exits 1 when any result was a NaN, Inf or saturated value that was not flagged.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "markdown_report.hpp"
#include "stability_sweeps.hpp"
#include "sweep_rows.hpp"

namespace rbdgrad::stability {
namespace {

SweepGrid full_grid() {
  SweepGrid g;
  g.states_per_point = 40;
  g.speed_points_per_decade = 4;
  g.ratio_points_per_decade = 2;
  g.robots = {"iiwa14", "panda", "hyq", "talos_reduced", "chain64", "tree64"};
  g.joint_counts = {1, 2, 4, 8, 16, 24, 32, 48, 64};
  g.models_per_count = 4;
  g.limit_fractions = {0, 1e-4, 1e-3, 1e-2, 0.1, 0.25, 0.5};
  g.singularity_offsets = {0, 1e-8, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1};
  return g;
}

// A smoke test's worth: every sweep at a few points.
SweepGrid quick_grid() {
  SweepGrid g;
  g.states_per_point = 3;
  g.robots = {"iiwa14", "chain64"};
  g.joint_counts = {1, 8, 64};
  g.models_per_count = 1;
  g.limit_fractions = {0, 0.5};
  g.singularity_offsets = {0, 1e-3};
  return g;
}

struct Options {
  std::string csv, markdown;
  bool quick = false;
};

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--csv") && has_value) o.csv = argv[++i];
    else if (!std::strcmp(argv[i], "--markdown") && has_value) o.markdown = argv[++i];
    else if (!std::strcmp(argv[i], "--quick")) o.quick = true;
    else return false;
  }
  return !o.csv.empty() && !o.markdown.empty();
}

int run(const Options& o) {
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const SweepGrid grid = o.quick ? quick_grid() : full_grid();
  const std::vector<PointSpec> plan = stability_plan(grid);
  std::vector<Point> points;
  ReportInfo info;
  info.states_per_point = grid.states_per_point;
  for (size_t i = 0; i < plan.size(); ++i) {
    const PointSpec& s = plan[i];
    std::fprintf(stderr, "\r[%4zu/%zu] %-13s %-13s x=%-8.3g gravity %-3s %6.0f s", i + 1, plan.size(), s.sweep.c_str(),
                 s.robot.c_str(), s.x, s.gravity ? "on" : "off", seconds());
    points.push_back(run_point(s, grid.states_per_point, static_cast<unsigned>(i + 1)));
    for (const Sample& sample : points.back().samples)
      for (const Outcome& outcome : sample.outcome) {
        ++info.results;
        info.silent_failures += outcome.silent_failure();
      }
  }
  std::fprintf(stderr, "\n");
  info.seconds = seconds();
  const std::vector<Row> rows = make_rows(points);
  std::ofstream csv(o.csv), md(o.markdown);
  if (!csv || !md) {
    std::fprintf(stderr, "stability_sweep: cannot write %s or %s\n", o.csv.c_str(), o.markdown.c_str());
    return 2;
  }
  write_csv(csv, rows);
  write_markdown(md, rows, info);
  if (!csv.flush() || !md.flush()) {
    std::fprintf(stderr, "stability_sweep: writing %s or %s failed\n", o.csv.c_str(), o.markdown.c_str());
    return 2;
  }
  std::fprintf(stderr, "%zu points, %ld results, %ld silent failures, %.0f s; wrote %s and %s\n", plan.size(),
               info.results, info.silent_failures, info.seconds, o.csv.c_str(), o.markdown.c_str());
  return info.silent_failures == 0 ? 0 : 1;
}

}  // namespace
}  // namespace rbdgrad::stability

int main(int argc, char** argv) {
  rbdgrad::stability::Options o;
  if (!rbdgrad::stability::parse(argc, argv, o)) {
    std::fprintf(stderr, "usage: %s --csv PATH --markdown PATH [--quick]\n", argv[0]);
    return 2;
  }
  return rbdgrad::stability::run(o);
}
