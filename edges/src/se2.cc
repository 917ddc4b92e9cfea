// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/se2.h"

namespace rvwo {
namespace {

// sin(w)/w and (1 - cos(w))/w, exact to double precision near w = 0 by their series.
void sinc_cosc(double w, double* a, double* b) {
  if (std::fabs(w) < 1e-4) {
    const double w2 = w * w;
    *a = 1.0 - w2 / 6.0;
    *b = w / 2.0 - w * w2 / 24.0;
  } else {
    *a = std::sin(w) / w;
    *b = (1.0 - std::cos(w)) / w;
  }
}

}  // namespace

SE2 SE2::compose(const SE2& other, Eigen::Matrix3d* J_this, Eigen::Matrix3d* J_other) const {
  const Eigen::Matrix2d R = rotation();
  const Eigen::Vector2d Rt = R * other.t_;
  if (J_this) {
    J_this->setIdentity();
    J_this->block<2, 1>(0, 2) = perp(Rt);
  }
  if (J_other) {
    J_other->setZero();
    J_other->block<2, 2>(0, 0) = R;
    (*J_other)(2, 2) = 1.0;
  }
  return SE2(t_ + Rt, theta_ + other.theta_);
}

SE2 SE2::inverse(Eigen::Matrix3d* J) const {
  const Eigen::Matrix2d Rt = rotation().transpose();
  const Eigen::Vector2d ti = -(Rt * t_);
  if (J) {
    J->setZero();
    J->block<2, 2>(0, 0) = -Rt;
    // d(-R^T t)/d theta = -(dR/dtheta)^T t = -(J R)^T t = R^T J t (J^T = -J).
    J->block<2, 1>(0, 2) = Rt * perp(t_);
    (*J)(2, 2) = -1.0;
  }
  return SE2(ti, -theta_);
}

SE2 SE2::between(const SE2& other, Eigen::Matrix3d* J_this, Eigen::Matrix3d* J_other) const {
  Eigen::Matrix3d J_inv, J_a;
  const SE2 inv = inverse(J_this ? &J_inv : nullptr);
  const SE2 out = inv.compose(other, J_this ? &J_a : nullptr, J_other);
  if (J_this) *J_this = J_a * J_inv;
  return out;
}

Eigen::Vector2d SE2::act(const Eigen::Vector2d& p, Eigen::Matrix<double, 2, 3>* J_pose,
                         Eigen::Matrix2d* J_point) const {
  const Eigen::Matrix2d R = rotation();
  const Eigen::Vector2d Rp = R * p;
  if (J_pose) {
    J_pose->block<2, 2>(0, 0).setIdentity();
    J_pose->col(2) = perp(Rp);
  }
  if (J_point) *J_point = R;
  return t_ + Rp;
}

SE2 SE2::exp(const Eigen::Vector3d& xi) {
  const double w = xi.z();
  double a, b;
  sinc_cosc(w, &a, &b);
  // V = [[a, -b], [b, a]]
  return SE2(Eigen::Vector2d(a * xi.x() - b * xi.y(), b * xi.x() + a * xi.y()), w);
}

Eigen::Vector3d SE2::log() const {
  const double w = theta_;
  double a, b;
  sinc_cosc(w, &a, &b);
  // V^-1 = 1 / (a^2 + b^2) [[a, b], [-b, a]]
  const double d = a * a + b * b;
  return {(a * t_.x() + b * t_.y()) / d, (-b * t_.x() + a * t_.y()) / d, w};
}

}  // namespace rvwo
