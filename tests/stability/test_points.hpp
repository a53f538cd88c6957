// The stability sweeps at the fast tests' grid, run once per test executable and shared by its tests.
#pragma once

#include <vector>

#include "stability_sweeps.hpp"

namespace rbdgrad::stability {

// A few points per sweep: decades of speed and of link ratios, 6 states per point, iiwa14 and the
// random 64-joint chain and tree, gravity on and off.
SweepGrid test_grid();

const std::vector<Point>& test_points();

// "velocity iiwa14 x=10 gravity on": names a point in failure messages
std::string describe(const PointSpec& p);

}  // namespace rbdgrad::stability
