#include "latency_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace rbdgrad::server {

LatencyModel::LatencyModel(std::vector<Point> points) {
  std::sort(points.begin(), points.end(), [](const Point& a, const Point& b) { return a.n < b.n; });
  for (std::size_t i = 0; i < points.size();) {
    std::size_t j = i;
    double sum = 0;
    int count = 0;
    for (; j < points.size() && points[j].n == points[i].n; ++j) {
      if (points[j].n == 0 || !std::isfinite(points[j].us) || points[j].us < 0) continue;
      sum += points[j].us;
      ++count;
    }
    if (count > 0) points_.push_back({points[i].n, sum / count});
    i = j;
  }
}

double LatencyModel::predict_us(std::uint64_t n) const noexcept {
  if (points_.empty()) return 0;
  if (n <= points_.front().n) return points_.front().us;
  const auto upper = std::lower_bound(points_.begin(), points_.end(), n,
                                      [](const Point& p, std::uint64_t value) { return p.n < value; });
  if (upper != points_.end()) {
    if (upper->n == n) return upper->us;
    const Point& a = *(upper - 1);
    const Point& b = *upper;
    const double f = static_cast<double>(n - a.n) / static_cast<double>(b.n - a.n);
    return a.us + f * (b.us - a.us);
  }
  // beyond the last point: the last segment's rate per state, never falling
  return points_.back().us + per_state_us() * static_cast<double>(n - points_.back().n);
}

double LatencyModel::per_state_us() const noexcept {
  if (points_.size() < 2) return 0;
  const Point& last = points_.back();
  const Point& before = points_[points_.size() - 2];
  return std::max(0.0, (last.us - before.us) / static_cast<double>(last.n - before.n));
}

std::string LatencyModel::summary() const {
  if (points_.empty()) return "no model";
  char text[200];
  if (points_.size() == 1) {
    std::snprintf(text, sizeof text, "%.4g us at every N (1 point)", points_.front().us);
    return text;
  }
  std::snprintf(text, sizeof text, "%.4g us at N = 1, %.4g us at N = %llu, then %.3g us/state (%zu points)",
                fixed_us(), points_.back().us, static_cast<unsigned long long>(points_.back().n), per_state_us(),
                points_.size());
  return text;
}

std::vector<Crossover> crossovers(const std::vector<const LatencyModel*>& models, std::uint64_t max_n) {
  std::vector<Crossover> out;
  auto fastest_at = [&](std::uint64_t n) {
    std::size_t best = models.size();
    double best_us = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < models.size(); ++i) {
      if (models[i] == nullptr || models[i]->empty()) continue;
      const double t = models[i]->predict_us(n);
      if (t < best_us) {
        best_us = t;
        best = i;
      }
    }
    return best;
  };
  for (std::uint64_t n = 1; n <= max_n; n = n < 64 ? n + 1 : n + std::max<std::uint64_t>(1, n / 16)) {
    const std::size_t best = fastest_at(n);
    if (best == models.size()) break;
    if (out.empty() || out.back().fastest != best) out.push_back({n, best});
  }
  return out;
}

}  // namespace rbdgrad::server
