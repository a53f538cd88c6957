// Rigid-body inertia accumulated in one body frame (internal to core/src): mass, first moment
// and rotational inertia about the frame's origin, to which bodies are added by mass, centre of
// mass and inertia about it. The URDF loader merges fixed links with it; lock_joints folds locked
// bodies into their parents.
#pragma once

#include <Eigen/Core>

namespace rbdgrad::detail {

struct InertiaSum {
  double m = 0;
  Eigen::Vector3d mc = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I_origin = Eigen::Matrix3d::Zero();

  static Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
    Eigen::Matrix3d S;
    S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return S;
  }
  // adds a body given its mass, com and inertia about the com, all in this frame
  void add(double mass, const Eigen::Vector3d& c, const Eigen::Matrix3d& Ic) {
    m += mass;
    mc += mass * c;
    I_origin += Ic - mass * skew(c) * skew(c);  // parallel axis theorem
  }
  // the centre of mass (the origin when massless) and the inertia about it, symmetrized
  Eigen::Vector3d com() const { return m > 0 ? Eigen::Vector3d(mc / m) : Eigen::Vector3d::Zero(); }
  Eigen::Matrix3d inertia_about_com() const {
    const Eigen::Vector3d c = com();
    const Eigen::Matrix3d I = I_origin + m * skew(c) * skew(c);
    return 0.5 * (I + I.transpose());
  }
};

}  // namespace rbdgrad::detail
