// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The wheels as the estimator keeps them: the odometry's readings, their calibration as local BA
// refines it, and the frames where tracking found them slipping. Tracking writes the readings and
// the slips, local mapping reads them and refines the calibration: each under its own lock.
// Private to the library.
#pragma once

#include <deque>
#include <mutex>
#include <optional>

#include "context.h"
#include "rvwo/ceres/costs.h"
#include "rvwo/edges/wheel_preintegration.h"

namespace rvwo::estimator {

class Wheels {
 public:
  explicit Wheels(const Context& ctx) : ctx_(ctx), odometry_(ctx.opt.wheel_noise, ctx.rig.T_b_o) {}

  void addPose(double t, const SE2& T_odom_o);
  void addAngles(double t, double q_left, double q_right);
  void addSpeeds(double t, double w_left, double w_right);

  // The wheels' motion between t0 and t1, clipped to the readings there are, integrated with the
  // calibration as estimated so far; none in vo mode or without odometry.
  std::optional<WheelDelta> delta(double t0, double t1) const;
  // The readings have passed t (a frame at t can be predicted).
  bool reached(double t) const;

  ceres_adapters::WheelCalibrationEstimate calibration() const;
  // What a local BA whose newest keyframe is at t learnt of the calibration.
  void refine(const WheelCalibration& c, double t);

  // A slip frame at t: vision overruled the wheels, or held the pose while they went on (spin: the
  // robot about stood, slipIsSpin).
  void markSlip(double t, bool spin);
  struct SlipCount {
    int frames = 0, spins = 0;
  };
  SlipCount slipsBetween(double t0, double t1) const;  // in (t0, t1]

  // The oldest keyframe in memory is at t: slips before it and readings a second before it go.
  void dropBefore(double t);

 private:
  const Context& ctx_;
  mutable std::mutex odometry_mutex_;
  WheelOdometry odometry_;
  ceres_adapters::WheelCalibrationEstimate calibration_;
  bool has_odometry_ = false;

  mutable std::mutex slip_mutex_;
  struct SlipMark {
    double t;
    bool spin;
  };
  std::deque<SlipMark> slip_marks_;  // since the oldest keyframe in memory
};

}  // namespace rvwo::estimator
