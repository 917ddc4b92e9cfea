// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "wheels.h"

#include <algorithm>

namespace rvwo::estimator {

void Wheels::addPose(double t, const SE2& T_odom_o) {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  odometry_.addPose(t, T_odom_o);
  has_odometry_ = true;
}

void Wheels::addAngles(double t, double q_left, double q_right) {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  odometry_.addWheelAngles(t, q_left, q_right, ctx_.opt.drive);
  has_odometry_ = true;
}

void Wheels::addSpeeds(double t, double w_left, double w_right) {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  odometry_.addWheelSpeeds(t, w_left, w_right, ctx_.opt.drive);
  has_odometry_ = true;
}

std::optional<WheelDelta> Wheels::delta(double t0, double t1) const {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  if (!has_odometry_ || ctx_.opt.mode == Mode::kVo || odometry_.empty()) return std::nullopt;
  t0 = std::max(t0, odometry_.firstTime());
  t1 = std::min(t1, odometry_.lastTime());
  if (!(t1 > t0)) return std::nullopt;
  return odometry_.integrate(t0, t1, calibration_.c);
}

bool Wheels::reached(double t) const {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  return !odometry_.empty() && odometry_.lastTime() >= t;
}

ceres_adapters::WheelCalibrationEstimate Wheels::calibration() const {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  return calibration_;
}

void Wheels::refine(const WheelCalibration& c, double t) {
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  calibration_.refined(c, t);
}

void Wheels::markSlip(double t, bool spin) {
  std::lock_guard<std::mutex> lock(slip_mutex_);
  slip_marks_.push_back({t, spin});
}

Wheels::SlipCount Wheels::slipsBetween(double t0, double t1) const {
  std::lock_guard<std::mutex> lock(slip_mutex_);
  SlipCount n;
  for (const SlipMark& m : slip_marks_) {
    if (m.t <= t0 || m.t > t1) continue;
    ++n.frames;
    n.spins += m.spin;
  }
  return n;
}

void Wheels::dropBefore(double t) {
  {
    std::lock_guard<std::mutex> lock(slip_mutex_);
    while (!slip_marks_.empty() && slip_marks_.front().t < t) slip_marks_.pop_front();
  }
  std::lock_guard<std::mutex> lock(odometry_mutex_);
  if (!odometry_.empty()) odometry_.dropBefore(t - 1.0);
}

}  // namespace rvwo::estimator
