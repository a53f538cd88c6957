// Spatial vector algebra (Featherstone), written out component-wise so nothing builds 6x6 cross
// operators. Motion vectors are [angular; linear], force vectors [moment; force]; all the core
// algorithms express them in the world frame, at the world origin.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products
#include <type_traits>

// The small spatial helpers must inline into the recursions; GCC's heuristics otherwise keep some
// of them out of line in the larger passes.
#if defined(__GNUC__)
#define RBDGRAD_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define RBDGRAD_ALWAYS_INLINE inline
#endif

namespace rbdgrad {

template <class S> using Vec3 = Eigen::Matrix<S, 3, 1>;
template <class S> using Vec6 = Eigen::Matrix<S, 6, 1>;
template <class S> using Mat3 = Eigen::Matrix<S, 3, 3>;
template <class S> using Mat6 = Eigen::Matrix<S, 6, 6>;
template <class S> using VectorX = Eigen::Matrix<S, Eigen::Dynamic, 1>;
template <class S> using MatrixX = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
// Vector argument of an algorithm: any contiguous vector (VectorX, Map) without a copy. Not used to
// deduce S, which comes from the model.
template <class S> using ConstVectorRef = std::type_identity_t<Eigen::Ref<const VectorX<S>>>;

// a x b for 3-vectors, written out so it inlines into the recursions (Eigen's cross is an
// out-of-line call on blocks)
template <class S, class A, class B, class Out>
RBDGRAD_ALWAYS_INLINE void cross3(const A& a, const B& b, Out&& out, bool add = false) {
  const S x = a(1) * b(2) - a(2) * b(1);
  const S y = a(2) * b(0) - a(0) * b(2);
  const S z = a(0) * b(1) - a(1) * b(0);
  if (add) {
    out(0) += x;
    out(1) += y;
    out(2) += z;
  } else {
    out(0) = x;
    out(1) = y;
    out(2) = z;
  }
}

// m1 x m2 (motion cross motion): [w1 x w2; w1 x v2 + v1 x w2]
template <class S>
RBDGRAD_ALWAYS_INLINE Vec6<S> cross_motion(const Vec6<S>& m1, const Vec6<S>& m2) {
  Vec6<S> out;
  cross3<S>(m1.template head<3>(), m2.template head<3>(), out.template head<3>());
  cross3<S>(m1.template head<3>(), m2.template tail<3>(), out.template tail<3>());
  cross3<S>(m1.template tail<3>(), m2.template head<3>(), out.template tail<3>(), true);
  return out;
}

// m x* f (motion cross force): [w x n + v x f; w x f]
template <class S>
RBDGRAD_ALWAYS_INLINE Vec6<S> cross_force(const Vec6<S>& m, const Vec6<S>& f) {
  Vec6<S> out;
  cross3<S>(m.template head<3>(), f.template head<3>(), out.template head<3>());
  cross3<S>(m.template tail<3>(), f.template tail<3>(), out.template head<3>(), true);
  cross3<S>(m.template head<3>(), f.template tail<3>(), out.template tail<3>());
  return out;
}

// power of a force along a motion: m . f
template <class S>
RBDGRAD_ALWAYS_INLINE S dot(const Vec6<S>& m, const Vec6<S>& f) {
  return m.dot(f);
}

template <class S>
inline Mat3<S> skew(const Vec3<S>& v) {
  Mat3<S> out;
  out << S(0), -v.z(), v.y(), v.z(), S(0), -v.x(), -v.y(), v.x(), S(0);
  return out;
}

// Spatial inertia at the world origin of a body with mass m, centre of mass c and rotational
// inertia Ic about c, all in world axes: [[Ic - m cx cx, m cx], [-m cx, m 1]].
template <class S>
inline void spatial_inertia(S m, const Vec3<S>& c, const Mat3<S>& Ic, Mat6<S>& out) {
  const Mat3<S> cx = skew(c);
  const Vec3<S> mc = m * c;
  const Mat3<S> mcx = skew(mc);
  out.template topLeftCorner<3, 3>() = Ic - mcx * cx;
  out.template topRightCorner<3, 3>() = mcx;
  out.template bottomLeftCorner<3, 3>() = -mcx;
  out.template bottomRightCorner<3, 3>() = Mat3<S>::Identity() * m;
}

}  // namespace rbdgrad
