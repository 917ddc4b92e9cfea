// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "sim/odometry.h"

#include <algorithm>
#include <cmath>

namespace rvwo::sim {

double motionTime(const Scenario& s, double t) {
  double slipped = 0;
  for (const auto& i : s.slip) slipped += std::clamp(t - i.t0, 0.0, i.t1 - i.t0);
  return t - slipped;
}

OdometrySimulator::OdometrySimulator(const Scenario& s, const Motion& motion, unsigned seed)
    : s_(s), motion_(motion), rng_(seed * 1000033u + 11u) {}  // a stream of its own

OdometryReading OdometrySimulator::step(double t) {
  const double t0 = last_t_, dt = t - t0;
  // The commanded motion over [t0, t]: while slipping, the motion the robot would have made
  // since the slip began (it stays where it is).
  double slip_start = -1;
  for (const auto& i : s_.slip) {
    if (i.contains(t0)) slip_start = i.t0;
  }
  const double m0 = motionTime(s_, t0);
  const SE2 cmd = slip_start >= 0 ? motion_.at(m0 + (t0 - slip_start)).between(motion_.at(m0 + (t - slip_start)))
                                  : motion_.at(m0).between(motion_.at(motionTime(s_, t)));
  const Eigen::Vector3d xi = cmd.log();
  const double r_l = kRadius * (1 + s_.radius_error), r_r = kRadius * (1 - s_.radius_error);
  const double track = kTrack * (1 + s_.track_error);
  const double dl = (xi.x() - xi.z() * track / 2) / r_l, dr = (xi.x() + xi.z() * track / 2) / r_r;
  meas_l_ += dl + s_.wheel_noise * std::sqrt(std::fabs(dl)) * gauss_(rng_);
  meas_r_ += dr + s_.wheel_noise * std::sqrt(std::fabs(dr)) * gauss_(rng_);
  const double tick = 2 * M_PI / s_.ticks_per_revolution;
  OdometryReading out;
  out.t = t;
  out.ticks_left = std::lround(meas_l_ / tick);
  out.ticks_right = std::lround(meas_r_ / tick);
  const double ql = (out.ticks_left - last_.ticks_left) * tick, qr = (out.ticks_right - last_.ticks_right) * tick;
  const double ds = 0.5 * kRadius * (ql + qr), dphi = kRadius * (qr - ql) / kTrack;
  out.pose = last_.pose * SE2::exp(Eigen::Vector3d(ds, 0, dphi));
  out.v = dt > 0 ? ds / dt : 0;
  out.omega = dt > 0 ? dphi / dt : 0;
  last_ = out;
  last_t_ = t;
  return out;
}

}  // namespace rvwo::sim
