// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Simulated wheel encoders on a differential drive. The wheels turn as the motion commands:
// with the robot, or, while it slips, as it would have moved (the robot stays). Error model:
//   - true radii r (1 + e_r) left, r (1 - e_r) right, true track b (1 + e_b), for nominal r, b;
//   - each wheel's angle gains white noise of density sigma_w (rad/sqrt(rad)): over an increment
//     dq, N(0, sigma_w^2 |dq|);
//   - the ticks are the noisy angle quantised to 2 pi / ticks_per_revolution;
//   - the robot's own odometry pose integrates the tick increments with the nominal r and b.
// A straight run of length D then reads, to first order, distance D / (1 - e_r^2) and heading
// 2 e_r D / ((1 - e_r^2) b), with heading variance r^2 sigma_w^2 (|Q_l| + |Q_r|) / b^2 for total
// wheel angles Q_l, Q_r (tests/apps/sim_test.cc checks these).
#pragma once

#include <random>

#include "sim/scenario.h"

namespace rvwo::sim {

struct OdometryReading {
  double t = 0;
  long ticks_left = 0, ticks_right = 0;  // cumulative
  SE2 pose;                              // the robot's own dead reckoning
  double v = 0, omega = 0;               // over the last increment, m/s and rad/s
};

class OdometrySimulator {
 public:
  static constexpr double kRadius = 0.08, kTrack = 0.40;  // nominal, m
  OdometrySimulator(const Scenario& s, const Motion& motion, unsigned seed);
  // The reading at time t (> the previous one), the wheels having turned since the last.
  OdometryReading step(double t);

 private:
  const Scenario& s_;
  const Motion& motion_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> gauss_{0.0, 1.0};
  double last_t_ = 0, meas_l_ = 0, meas_r_ = 0;
  OdometryReading last_;
};

// Time along the motion at clock time t: it stands still while the wheels slip.
double motionTime(const Scenario& s, double t);

}  // namespace rvwo::sim
