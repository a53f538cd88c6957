// How long a backend takes for a batch of N states of one model in one precision: the scheduler's
// cost model. Measured points (N, microseconds) from calibration, or a model the backend gives
// itself (the FPGA's cycle count), joined piecewise linearly: a GPU's time is flat until it fills
// up and then grows with N, which one straight line fits badly. Between points the time is
// interpolated; below the first point it is the first point's; beyond the last it grows at the
// last segment's rate per state.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rbdgrad::server {

class LatencyModel {
 public:
  struct Point {
    std::uint64_t n = 0;
    double us = 0;
    bool operator==(const Point&) const = default;
  };

  LatencyModel() = default;
  /// Points in any order; points of equal N are averaged, non-finite or negative times dropped.
  explicit LatencyModel(std::vector<Point> points);

  bool empty() const noexcept { return points_.empty(); }
  const std::vector<Point>& points() const noexcept { return points_; }

  /// Predicted microseconds for a batch of n >= 1 states; 0 for an empty model.
  double predict_us(std::uint64_t n) const noexcept;

  /// For people (the scheduler uses predict_us): the time of one state, and the rate per state
  /// beyond the last point (the last segment's, never negative; 0 for one point). 0 when empty.
  double fixed_us() const noexcept { return predict_us(1); }
  double per_state_us() const noexcept;

  /// "9.7 us at N = 1, 1310 us at N = 1024, then 1.27 us/state (6 points)".
  std::string summary() const;

 private:
  std::vector<Point> points_;  // ascending N, one per N
};

/// The batch sizes at which the fastest of `models` changes, up to max_n: for each change, the
/// first N where the new one is fastest and its index in `models`. Empty models are skipped.
/// The first entry is the fastest at N = 1. Scanned over every N in [1, 64], then in steps of
/// about 1/16 of N (so a crossover is found to within about 6%).
struct Crossover {
  std::uint64_t n = 0;
  std::size_t fastest = 0;
  bool operator==(const Crossover&) const = default;
};
std::vector<Crossover> crossovers(const std::vector<const LatencyModel*>& models, std::uint64_t max_n);

}  // namespace rbdgrad::server
