// Tests for plugins/cuda/device/inertia_parameters.hpp (the block kernel's lean working set keeps
// the inertias and their rates by nine parameters) against the 6x6 matrices of the core's spatial
// algebra: the products and the rate's parameters, for random bodies and velocities.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "device/inertia_parameters.hpp"
#include "rbdgrad/spatial.hpp"

namespace rbdgrad::testing {
namespace {

using Mat6d = Mat6<double>;
using Vec6d = Vec6<double>;

// A body's inertia at the world origin: positive mass, a centre of mass a metre or so away, a
// random symmetric rotational inertia about it.
Mat6d random_inertia(std::mt19937& rng, double& mass) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  mass = 0.5 + 4.0 * (u(rng) + 1.0);
  const Vec3<double> c(u(rng), u(rng), u(rng));
  Mat3<double> A;
  for (int k = 0; k < 9; ++k) A(k / 3, k % 3) = u(rng);
  const Mat3<double> Ic = A * A.transpose() + Mat3<double>::Identity() * 0.1;
  Mat6d I;
  spatial_inertia(mass, c, Ic, I);
  return I;
}

// The nine parameters of a matrix of the inertias' form [J, h x; -h x, m 1]: h from the top-right
// block h x (h_0 at its (2, 1), h_1 at (0, 2), h_2 at (1, 0)), then J's upper triangle.
std::array<double, 9> parameters_of(const Mat6d& I) {
  std::array<double, 9> p{};
  p[0] = I(2, 4);
  p[1] = I(0, 5);
  p[2] = I(1, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) p[cuda::inertia_j_index(r, c)] = I(r, c);
  return p;
}

Vec6d random_vector(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Vec6d v;
  for (int k = 0; k < 6; ++k) v(k) = u(rng);
  return v;
}

// x -> m x* x as a matrix (the force cross product), column by column
Mat6d cross_force_matrix(const Vec6d& m) {
  Mat6d out;
  for (int k = 0; k < 6; ++k) out.col(k) = cross_force(m, Vec6d(Vec6d::Unit(k)));
  return out;
}
Mat6d cross_motion_matrix(const Vec6d& m) {
  Mat6d out;
  for (int k = 0; k < 6; ++k) out.col(k) = cross_motion(m, Vec6d(Vec6d::Unit(k)));
  return out;
}

TEST(InertiaParameters, IndexTheUpperTriangleAfterTheFirstMoment) {
  EXPECT_EQ(cuda::inertia_j_index(0, 0), 3);
  EXPECT_EQ(cuda::inertia_j_index(0, 2), 5);
  EXPECT_EQ(cuda::inertia_j_index(1, 1), 6);
  EXPECT_EQ(cuda::inertia_j_index(2, 1), 7);
  EXPECT_EQ(cuda::inertia_j_index(2, 2), 8);
  // every entry: the upper triangle row by row at 3..8, the lower one its mirror
  int next = 3;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      if (c >= r) {
        EXPECT_EQ(cuda::inertia_j_index(r, c), next++) << r << ", " << c;
      }
      EXPECT_EQ(cuda::inertia_j_index(r, c), cuda::inertia_j_index(c, r)) << r << ", " << c;
    }
}

TEST(InertiaParameters, ProductsMatchTheSpatialInertiaMatrix) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    double mass = 0;
    const Mat6d I = random_inertia(rng, mass);
    // the form the parameters stand for
    const Mat3<double> off_diagonal = I.topRightCorner<3, 3>() + I.bottomLeftCorner<3, 3>();
    ASSERT_LT(off_diagonal.norm(), 1e-12);
    const std::array<double, 9> P = parameters_of(I);
    const Vec6d x = random_vector(rng), Ix = I * x;
    for (int c = 0; c < 6; ++c)
      EXPECT_NEAR(cuda::block::inertia_row_dot(P.data(), 0, c, x.data(), mass), Ix(c), 1e-12 * (1 + Ix.norm()))
          << "trial " << trial << ", component " << c;
  }
}

// The rate v x* I - I v x is symmetric, has the inertias' form with zero mass, and its parameters
// are inertia_rate_parameter's; its product is rate_row_dot's.
TEST(InertiaParameters, RateMatchesTheMatrixForm) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    double mass = 0;
    const Mat6d I = random_inertia(rng, mass);
    const Vec6d v = random_vector(rng);
    const Mat6d rate = cross_force_matrix(v) * I - I * cross_motion_matrix(v);
    const double scale = 1 + rate.norm();
    ASSERT_LT((rate - rate.transpose()).norm(), 1e-12 * scale) << "trial " << trial;
    const Mat3<double> mass_rate = rate.bottomRightCorner<3, 3>();
    ASSERT_LT(mass_rate.norm(), 1e-12 * scale) << "trial " << trial;
    const Mat3<double> off_diagonal = rate.topRightCorner<3, 3>() + rate.bottomLeftCorner<3, 3>();
    ASSERT_LT(off_diagonal.norm(), 1e-12 * scale) << "trial " << trial;
    const std::array<double, 9> P = parameters_of(I), expected = parameters_of(rate);
    std::array<double, 9> got{};
    for (int e = 0; e < 9; ++e) {
      got[e] = cuda::block::inertia_rate_parameter(P.data(), mass, v.data(), e);
      EXPECT_NEAR(got[e], expected[e], 1e-12 * scale) << "trial " << trial << ", parameter " << e;
    }
    const Vec6d x = random_vector(rng), Rx = rate * x;
    for (int c = 0; c < 6; ++c)
      EXPECT_NEAR(cuda::block::rate_row_dot(got.data(), 0, c, x.data()), Rx(c), 1e-12 * scale * (1 + x.norm()))
          << "trial " << trial << ", component " << c;
  }
}

// Rows r and 3 + r at once (the lean passes' items of two components) are the rows one at a time,
// with the mass (an inertia) and without (a rate), at a body past the first: the same operations
// (to rounding: a host compiler may fuse multiplies and adds differently in the two forms).
TEST(InertiaParameters, RowPairsAreTheRowsOneAtATime) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 50; ++trial) {
    double m0 = 0, m1 = 0;
    const std::array<double, 9> p0 = parameters_of(random_inertia(rng, m0)), p1 = parameters_of(random_inertia(rng, m1));
    std::array<double, 2 * cuda::kInertiaParameterStride> both{};
    std::copy(p0.begin(), p0.end(), both.begin());
    std::copy(p1.begin(), p1.end(), both.begin() + cuda::kInertiaParameterStride);
    const Vec6d x = random_vector(rng);
    double p_sum = m1;
    for (const double v : p1) p_sum += std::abs(v);
    const double tol = 1e-14 * (1 + x.norm()) * (1 + p_sum);
    for (int r = 0; r < 3; ++r) {
      double angular = 0, linear = 0;
      cuda::block::parameter_rows_dot<true>(both.data(), 1, r, x.data(), m1, angular, linear);
      EXPECT_NEAR(angular, cuda::block::inertia_row_dot(both.data(), 1, r, x.data(), m1), tol) << trial << ", " << r;
      EXPECT_NEAR(linear, cuda::block::inertia_row_dot(both.data(), 1, 3 + r, x.data(), m1), tol) << trial << ", " << r;
      cuda::block::parameter_rows_dot<false>(both.data(), 1, r, x.data(), 0.0, angular, linear);
      EXPECT_NEAR(angular, cuda::block::rate_row_dot(both.data(), 1, r, x.data()), tol) << trial << ", " << r;
      EXPECT_NEAR(linear, cuda::block::rate_row_dot(both.data(), 1, 3 + r, x.data()), tol) << trial << ", " << r;
    }
  }
}

// Bodies kInertiaParameterStride apart: body i's product reads body i's parameters.
TEST(InertiaParameters, ReadsTheBodyAtItsStride) {
  std::mt19937 rng(3);
  double m0 = 0, m1 = 0;
  const Mat6d I0 = random_inertia(rng, m0), I1 = random_inertia(rng, m1);
  std::array<double, 2 * cuda::kInertiaParameterStride> both{};
  const std::array<double, 9> p0 = parameters_of(I0), p1 = parameters_of(I1);
  std::copy(p0.begin(), p0.end(), both.begin());
  std::copy(p1.begin(), p1.end(), both.begin() + cuda::kInertiaParameterStride);
  const Vec6d x = random_vector(rng), I1x = I1 * x;
  for (int c = 0; c < 6; ++c)
    EXPECT_NEAR(cuda::block::inertia_row_dot(both.data(), 1, c, x.data(), m1), I1x(c), 1e-12 * (1 + I1x.norm()));
}

}  // namespace
}  // namespace rbdgrad::testing
