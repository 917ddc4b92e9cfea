// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// SE(2): a planar rigid motion T = (R(theta), t). Conventions:
//   - frames in names: T_w_b maps body coordinates into the world, p_w = T_w_b * p_b;
//   - a pose as a solver variable is the vector (x, y, theta) updated additively with theta
//     wrapped, exactly as g2o's VertexSE2 does; the edges' Jacobians are with respect to it;
//   - exp/log use the twist xi = (v_x, v_y, omega) with T = exp(xi) the motion after one unit of
//     time at constant body velocity;
//   - J = [[0, -1], [1, 0]], so d R(theta) / d theta = J R(theta).
// Jacobian outputs are optional (nullptr: not computed).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace rvwo {

// Angle in (-pi, pi].
inline double wrapAngle(double a) {
  constexpr double kPi = 3.14159265358979323846, kTwoPi = 2.0 * kPi;
  if (a > -kPi && a <= kPi) return a;
  a = std::fmod(a + kPi, kTwoPi);
  if (a <= 0.0) a += kTwoPi;
  return a - kPi;
}

inline Eigen::Matrix2d rotation2(double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

// J = [[0, -1], [1, 0]]: J v is v turned by +90 degrees.
inline Eigen::Vector2d perp(const Eigen::Vector2d& v) { return {-v.y(), v.x()}; }

class SE2 {
 public:
  SE2() = default;
  SE2(double x, double y, double theta) : t_(x, y), theta_(wrapAngle(theta)) {}
  SE2(const Eigen::Vector2d& t, double theta) : t_(t), theta_(wrapAngle(theta)) {}
  // From the solver vector (x, y, theta).
  static SE2 fromVector(const Eigen::Vector3d& v) { return SE2(v.x(), v.y(), v.z()); }
  Eigen::Vector3d vector() const { return {t_.x(), t_.y(), theta_}; }

  const Eigen::Vector2d& translation() const { return t_; }
  double angle() const { return theta_; }
  Eigen::Matrix2d rotation() const { return rotation2(theta_); }
  // The same pose in 3-D, on the plane z = 0 (rotation about z).
  Eigen::Isometry3d isometry3() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear().topLeftCorner<2, 2>() = rotation();
    T.translation().head<2>() = t_;
    return T;
  }

  // this * other. Jacobians of the result's (x, y, theta) w.r.t. each operand's (x, y, theta).
  SE2 compose(const SE2& other, Eigen::Matrix3d* J_this = nullptr, Eigen::Matrix3d* J_other = nullptr) const;
  SE2 operator*(const SE2& other) const { return compose(other); }
  // this^-1, Jacobian of its (x, y, theta) w.r.t. this (x, y, theta).
  SE2 inverse(Eigen::Matrix3d* J = nullptr) const;
  // this^-1 * other (the motion from this to other, in this frame).
  SE2 between(const SE2& other, Eigen::Matrix3d* J_this = nullptr, Eigen::Matrix3d* J_other = nullptr) const;
  // T * p, with Jacobians w.r.t. (x, y, theta) and p.
  Eigen::Vector2d act(const Eigen::Vector2d& p, Eigen::Matrix<double, 2, 3>* J_pose = nullptr,
                      Eigen::Matrix2d* J_point = nullptr) const;

  // Group exponential and logarithm of the twist (v_x, v_y, omega); exact near omega = 0.
  static SE2 exp(const Eigen::Vector3d& xi);
  Eigen::Vector3d log() const;
  // The additive update of the solver vector (g2o VertexSE2): (x + d0, y + d1, wrap(theta + d2)).
  SE2 oplus(const Eigen::Vector3d& delta) const { return SE2(t_ + delta.head<2>(), theta_ + delta.z()); }

  // Interpolation along the constant-twist path from identity to this: exp(f * log(this)).
  SE2 fraction(double f) const { return exp(f * log()); }

 private:
  Eigen::Vector2d t_ = Eigen::Vector2d::Zero();
  double theta_ = 0.0;
};

}  // namespace rvwo
