// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/wheel_preintegration.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace rvwo {
namespace {

std::string str(double v) {
  std::ostringstream o;
  o.precision(17);
  o << v;
  return o.str();
}

void nonNegative(double v, const char* key) {
  if (!(v >= 0.0 && std::isfinite(v))) {
    throw std::invalid_argument(std::string(key) + ": must be finite and >= 0, got " + str(v));
  }
}

}  // namespace

void WheelNoise::validate() const {
  nonNegative(sigma_x, "Odometry.NoiseX");
  nonNegative(sigma_y, "Odometry.NoiseY");
  nonNegative(sigma_phi, "Odometry.NoiseRot");
  nonNegative(sigma_phi_s, "Odometry.NoiseRotPerMetre");
  nonNegative(sigma_wheel, "Odometry.NoiseWheel");
  nonNegative(floor_p, "Odometry.NoiseFloorP");
  nonNegative(floor_phi, "Odometry.NoiseFloorRot");
}

Eigen::Matrix3d WheelNoise::poseReadingCovariance(double ds, double dphi, double dt) const {
  ds = std::fabs(ds);
  dphi = std::fabs(dphi);
  const double fp = floor_p * floor_p * dt;
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  s(0, 0) = sigma_x * sigma_x * ds + fp;
  s(1, 1) = sigma_y * sigma_y * ds + fp;
  s(2, 2) = sigma_phi * sigma_phi * dphi + sigma_phi_s * sigma_phi_s * ds + floor_phi * floor_phi * dt;
  return s;
}

void DiffDriveParams::validate() const {
  if (!(radius_left > 0 && radius_right > 0 && track > 0 && std::isfinite(radius_left + radius_right + track))) {
    throw std::invalid_argument("Odometry: wheel radii and track must be finite and > 0");
  }
}

Eigen::Matrix3d calibrationTwistJacobian(const Eigen::Vector3d& xi) {
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  E(0, 0) = xi.x();  // v_x (1 + c_s)
  E(2, 1) = xi.z();  // w (1 + c_w)
  E(2, 2) = xi.x();  // + c_k v_x
  return E;
}

Eigen::Matrix3d se2ExpJacobian(const Eigen::Vector3d& xi) {
  // t = V(w) v, V = [[a, -b], [b, a]], a = sin w / w, b = (1 - cos w) / w (series near 0).
  const double w = xi.z();
  double a, b, da, db;
  if (std::fabs(w) < 1e-4) {
    a = 1.0 - w * w / 6.0;
    b = 0.5 * w - w * w * w / 24.0;
    da = -w / 3.0;
    db = 0.5 - w * w / 8.0;
  } else {
    a = std::sin(w) / w;
    b = (1.0 - std::cos(w)) / w;
    da = (w * std::cos(w) - std::sin(w)) / (w * w);
    db = (w * std::sin(w) - 1.0 + std::cos(w)) / (w * w);
  }
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  J << a, -b, da * xi.x() - db * xi.y(), b, a, db * xi.x() + da * xi.y(), 0, 0, 1;
  return J;
}

void WheelPreintegrator::integrate(const Eigen::Vector2d& dp, double dphi, const Eigen::Matrix3d& sigma_n,
                                   Eigen::Matrix3d* A_out, Eigen::Matrix3d* B_out, const Eigen::Matrix3d& C) {
  const Eigen::Matrix2d R = rotation2(dphi_);
  const Eigen::Vector2d Rdp = R * dp;
  // eq. 12: A_k = [[I, J R(Dphi) dp], [0, 1]], B_k = [[R(Dphi), 0], [0, 1]]
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  A.block<2, 1>(0, 2) = perp(Rdp);
  Eigen::Matrix3d B = Eigen::Matrix3d::Identity();
  B.block<2, 2>(0, 0) = R;
  cov_ = A * cov_ * A.transpose() + B * sigma_n * B.transpose();  // eq. 13
  H_ = A * H_ + B * C;                                            // the calibration's, alike
  dp_ += Rdp;                                                     // eq. 11
  dphi_ += dphi;
  if (A_out) *A_out = A;
  if (B_out) *B_out = B;
}

WheelDelta WheelDelta::recalibrated(const WheelCalibration& c) const {
  WheelDelta out = *this;
  const Eigen::Vector3d v = at(c);
  out.dp = v.head<2>();
  out.dphi = v.z();
  out.calibration = c;
  return out;
}

WheelDelta compose(const WheelDelta& a, const WheelDelta& b) {
  if (!(std::fabs(a.t1 - b.t0) <= 1e-9 * std::max(1.0, std::fabs(a.t1)))) {
    throw std::invalid_argument("compose: the deltas do not meet (the first ends at t=" + str(a.t1) +
                                ", the second starts at t=" + str(b.t0) + ")");
  }
  if (a.calibration != b.calibration) {
    throw std::invalid_argument(
        "compose: the deltas were integrated with different calibrations (recalibrated() first)");
  }
  const Eigen::Matrix2d R = rotation2(a.dphi);
  const Eigen::Vector2d Rdp = R * b.dp;
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  A.block<2, 1>(0, 2) = perp(Rdp);
  Eigen::Matrix3d B = Eigen::Matrix3d::Identity();
  B.block<2, 2>(0, 0) = R;
  WheelDelta out;
  out.t0 = a.t0;
  out.t1 = b.t1;
  out.dp = a.dp + Rdp;
  out.dphi = a.dphi + b.dphi;
  out.covariance = A * a.covariance * A.transpose() + B * b.covariance * B.transpose();
  out.distance = a.distance + b.distance;
  out.rotation = a.rotation + b.rotation;
  out.calibration = a.calibration;
  out.d_calibration = A * a.d_calibration + B * b.d_calibration;
  return out;
}

WheelOdometry::WheelOdometry(const WheelNoise& noise, const SE2& T_b_o) : noise_(noise), T_b_o_(T_b_o) {
  noise_.validate();
}

void WheelOdometry::checkReading(double t, Input kind, std::initializer_list<double> values) {
  if (!std::isfinite(t)) throw std::invalid_argument("odometry: timestamp is not finite");
  for (double v : values) {
    if (!std::isfinite(v)) throw std::invalid_argument("odometry: NaN or infinite value in the reading at t=" + str(t));
  }
  if (input_ != Input::kNone && input_ != kind) {
    throw std::invalid_argument("odometry: reading kinds mixed in one stream (poses, wheel angles, wheel speeds)");
  }
  if (has_last_ && !(t > last_t_)) {
    throw std::invalid_argument("odometry: timestamps must increase, got t=" + str(t) + " after t=" + str(last_t_));
  }
  input_ = kind;
}

void WheelOdometry::addPose(double t, const SE2& T_odom_o) {
  checkReading(t, Input::kPose, {T_odom_o.translation().x(), T_odom_o.translation().y(), T_odom_o.angle()});
  if (has_last_) {
    const SE2 inc = last_pose_.between(T_odom_o);
    const Eigen::Vector3d xi = inc.log();  // the constant-twist arc through both poses
    const double ds = xi.head<2>().norm(), dt = t - last_t_;
    segments_.push_back({last_t_, t, inc, xi, noise_.poseReadingCovariance(ds, xi.z(), dt), ds, std::fabs(xi.z())});
  }
  last_pose_ = T_odom_o;
  last_t_ = t;
  has_last_ = true;
}

void WheelOdometry::addWheelAngles(double t, double q_left, double q_right, const DiffDriveParams& drive) {
  checkReading(t, Input::kWheelAngles, {q_left, q_right});
  drive.validate();
  if (has_last_) pushWheelIncrement(t, q_left - last_a_, q_right - last_b_, drive);
  last_a_ = q_left;
  last_b_ = q_right;
  last_t_ = t;
  has_last_ = true;
}

void WheelOdometry::addWheelSpeeds(double t, double w_left, double w_right, const DiffDriveParams& drive) {
  checkReading(t, Input::kWheelSpeeds, {w_left, w_right});
  drive.validate();
  if (has_last_) {
    const double dt = t - last_t_;
    pushWheelIncrement(t, 0.5 * (last_a_ + w_left) * dt, 0.5 * (last_b_ + w_right) * dt, drive);
  }
  last_a_ = w_left;
  last_b_ = w_right;
  last_t_ = t;
  has_last_ = true;
}

void WheelOdometry::pushWheelIncrement(double t, double dq_l, double dq_r, const DiffDriveParams& drive) {
  const double rl = drive.radius_left, rr = drive.radius_right, tw = drive.track;
  const double ds = 0.5 * (rl * dq_l + rr * dq_r);
  const double w = (rr * dq_r - rl * dq_l) / tw;
  // The increment is the exact constant-curvature arc exp(ds, 0, w); docs/maths.md's
  // (ds cos(w/2), ds sin(w/2)) is its first-order form.
  const Eigen::Vector3d xi(ds, 0.0, w);
  const SE2 inc = SE2::exp(xi);
  // d(tx, ty, phi)/d(ds, w): the exponential's Jacobian without its v_y column.
  const Eigen::Matrix3d J_exp = se2ExpJacobian(xi);
  Eigen::Matrix<double, 3, 2> d_inc_d_sw;
  d_inc_d_sw << J_exp.col(0), J_exp.col(2);
  Eigen::Matrix2d d_sw_d_q;
  d_sw_d_q << 0.5 * rl, 0.5 * rr, -rl / tw, rr / tw;
  const Eigen::Matrix<double, 3, 2> G = d_inc_d_sw * d_sw_d_q;
  const double sw2 = noise_.sigma_wheel * noise_.sigma_wheel;
  const Eigen::Vector2d wheel_var(sw2 * std::fabs(dq_l), sw2 * std::fabs(dq_r));
  const double dt = t - last_t_;
  Eigen::Matrix3d sigma_n = G * wheel_var.asDiagonal() * G.transpose();
  sigma_n(0, 0) += noise_.floor_p * noise_.floor_p * dt;
  sigma_n(1, 1) += noise_.sigma_y * noise_.sigma_y * std::fabs(ds) + noise_.floor_p * noise_.floor_p * dt;
  sigma_n(2, 2) += noise_.floor_phi * noise_.floor_phi * dt;
  segments_.push_back({last_t_, t, inc, xi, sigma_n, std::fabs(ds), std::fabs(w)});
}

double WheelOdometry::firstTime() const {
  if (segments_.empty()) throw std::out_of_range("odometry: fewer than two readings");
  return segments_.front().t0;
}

double WheelOdometry::lastTime() const {
  if (segments_.empty()) throw std::out_of_range("odometry: fewer than two readings");
  return segments_.back().t1;
}

WheelDelta WheelOdometry::integrate(double t0, double t1, const WheelCalibration& c) const {
  if (segments_.empty() || !(t0 >= segments_.front().t0) || !(t1 <= segments_.back().t1) || !(t0 <= t1)) {
    std::ostringstream o;
    o.precision(17);
    o << "odometry: cannot integrate from t=" << t0 << " to t=" << t1 << ": readings cover ";
    if (segments_.empty()) {
      o << "nothing yet";
    } else {
      o << "[" << segments_.front().t0 << ", " << segments_.back().t1 << "]";
    }
    throw std::out_of_range(o.str());
  }
  WheelPreintegrator pre;
  WheelDelta out;
  out.t0 = t0;
  out.t1 = t1;
  auto it =
      std::upper_bound(segments_.begin(), segments_.end(), t0, [](double t, const Segment& s) { return t < s.t1; });
  for (; it != segments_.end() && it->t0 < t1; ++it) {
    const double span = it->t1 - it->t0;
    const double fa = std::max(0.0, (t0 - it->t0) / span), fb = std::min(1.0, (t1 - it->t0) / span);
    const double f = fb - fa;
    if (f <= 0.0) continue;
    // A part of a reading: the same fraction of its constant-twist arc, and of its noise (which
    // is linear in the distance, rotation and time it covers); its twist corrected by c.
    const Eigen::Vector3d xi = f * it->xi;
    const Eigen::Matrix3d E = calibrationTwistJacobian(xi);
    const SE2 piece = c.isZero() ? (f == 1.0 ? it->increment : it->increment.fraction(f)) : SE2::exp(xi + E * c);
    const Eigen::Matrix3d C = se2ExpJacobian(xi + E * c) * E;
    pre.integrate(piece.translation(), piece.angle(), f * it->sigma_n, nullptr, nullptr, C);
    out.distance += f * it->ds;
    out.rotation += f * it->dphi_abs;
  }
  // From the odometry frame o to the body: D_b = T_b_o D_o T_o_b, so dphi is unchanged and
  // dp_b = t + R(beta) dp_o - R(dphi) t, with Jacobian G = [[R(beta), -J R(dphi) t], [0, 1]].
  const Eigen::Vector2d& t = T_b_o_.translation();
  const Eigen::Matrix2d R_beta = T_b_o_.rotation();
  const Eigen::Vector2d R_dphi_t = rotation2(pre.dphi()) * t;
  out.dp = t + R_beta * pre.dp() - R_dphi_t;
  out.dphi = pre.dphi();
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
  G.block<2, 2>(0, 0) = R_beta;
  G.block<2, 1>(0, 2) = -perp(R_dphi_t);
  out.covariance = G * pre.covariance() * G.transpose();
  out.calibration = c;
  out.d_calibration = G * pre.calibrationJacobian();
  return out;
}

void WheelOdometry::dropBefore(double t) {
  while (!segments_.empty() && segments_.front().t1 < t) segments_.pop_front();
}

}  // namespace rvwo
