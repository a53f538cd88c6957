// Tests for server/latency_model.cpp: interpolation, extrapolation, the summary line and the
// crossovers between backends.
#include "latency_model.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace rbdgrad::server {
namespace {

TEST(LatencyModel, InterpolatesBetweenPointsAndExtrapolatesAtTheLastRate) {
  const LatencyModel m({{16, 30}, {1, 20}, {256, 60}, {16, 34}});  // unordered, N 16 twice
  ASSERT_EQ(m.points().size(), 3u);
  EXPECT_EQ(m.points()[1], (LatencyModel::Point{16, 32}));  // averaged
  EXPECT_DOUBLE_EQ(m.predict_us(1), 20);
  EXPECT_DOUBLE_EQ(m.predict_us(16), 32);
  EXPECT_DOUBLE_EQ(m.predict_us(136), 46);   // halfway from 16 to 256
  EXPECT_DOUBLE_EQ(m.predict_us(496), 88);   // 60 + 240 * (28 / 240)
  EXPECT_DOUBLE_EQ(LatencyModel({{64, 10}}).predict_us(1), 10);  // flat below the first point
  EXPECT_DOUBLE_EQ(LatencyModel({{64, 10}}).predict_us(1000), 10);  // one point: flat everywhere
  // a last segment that falls (noise) does not predict shorter times for larger batches
  EXPECT_DOUBLE_EQ(LatencyModel({{1, 10}, {2, 9}}).predict_us(100), 9);
  EXPECT_EQ(LatencyModel().predict_us(5), 0);
}

TEST(LatencyModel, DropsMeaninglessPoints) {
  const LatencyModel m({{0, 5}, {4, NAN}, {8, -1}, {8, 3}, {16, INFINITY}});
  ASSERT_EQ(m.points().size(), 1u);
  EXPECT_EQ(m.points()[0], (LatencyModel::Point{8, 3}));
  EXPECT_TRUE(LatencyModel({{0, 1}}).empty());
}

TEST(LatencyModel, FirstStateAndRateForPeople) {
  const LatencyModel m({{1, 12}, {11, 32}, {21, 62}});
  EXPECT_DOUBLE_EQ(m.fixed_us(), 12);
  EXPECT_DOUBLE_EQ(m.per_state_us(), 3);  // the last segment's
  EXPECT_EQ(m.summary(), "12 us at N = 1, 62 us at N = 21, then 3 us/state (3 points)");
  EXPECT_EQ(LatencyModel({{64, 10}}).summary(), "10 us at every N (1 point)");
  EXPECT_EQ(LatencyModel({{64, 10}}).per_state_us(), 0);
  EXPECT_EQ(LatencyModel().summary(), "no model");
}

TEST(LatencyModel, CrossoversOfThreeBackends) {
  // an FPGA-like model: 5 us per state; a CPU: 20 us + 1 us/state; a GPU: 200 us flat to 4096
  const LatencyModel fpga({{1, 5}, {1000, 5000}});
  const LatencyModel cpu({{1, 21}, {1000, 1020}});
  const LatencyModel gpu({{1, 200}, {4096, 200}, {8192, 400}});
  const std::vector<Crossover> c = crossovers({&fpga, &cpu, &gpu}, 100000);
  // fpga until 5 n > 20 + n (n > 5), cpu until 20 + n > 200 (n > 180), then gpu
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0], (Crossover{1, 0}));
  EXPECT_EQ(c[1], (Crossover{6, 1}));
  EXPECT_EQ(c[2].fastest, 2u);
  EXPECT_GE(c[2].n, 181u);
  EXPECT_LE(c[2].n, 181u + 181u / 16 + 1);
  // an empty model is no candidate; none at all, no crossover
  const LatencyModel none;
  EXPECT_EQ(crossovers({&none, &cpu}, 100), (std::vector<Crossover>{{1, 1}}));
  EXPECT_TRUE(crossovers({&none}, 100).empty());
}

}  // namespace
}  // namespace rbdgrad::server
