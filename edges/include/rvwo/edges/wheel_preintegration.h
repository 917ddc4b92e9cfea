// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Wheel-odometry preintegration on SE(2) (RVWO paper eqs. 11 to 13; docs/maths.md section 4).
//
// Readings give body-frame increments (dp_k, dphi_k). Between two frames they are accumulated
//
//   Dphi_{k+1} = Dphi_k + dphi_k,        Dp_{k+1} = Dp_k + R(Dphi_k) dp_k           (eq. 11)
//
// and the error of (Dp, Dphi), additive in the frame of the first pose, is propagated with the
// step Jacobians (eqs. 12, 13; the paper's A is garbled in print, this is the derived one):
//
//   A_k = [[I2, J R(Dphi_k) dp_k], [0, 1]],   B_k = [[R(Dphi_k), 0], [0, 1]]
//   Sigma_{k+1} = A_k Sigma_k A_k^T + B_k Sigma_n,k B_k^T
//
// Sigma_n,k scales with the motion the reading covers (distance, rotation, time), never with the
// number of readings, so the result does not depend on the odometry rate (WheelNoise).
//
// Calibration (beyond the paper: real wheels are never the nominal ones, and a bias is not noise).
// Each reading's twist xi = (v_x, v_y, w) = log(increment) in the odometry frame is corrected by
// c = (c_s, c_w, c_k):
//
//   xi'(c) = (v_x (1 + c_s), v_y, w (1 + c_w) + c_k v_x)
//
// c_s scales the distance, c_w the turn, c_k (rad/m) bends a straight drive; a differential drive
// whose radii are off by d_l, d_r and track by d_b has, to first order, c_s = (d_l + d_r)/2,
// c_w = (d_l + d_r)/2 - d_b, c_k = (d_r - d_l)/b. The Jacobian of the delta w.r.t. c is
// propagated beside the covariance (as GTSAM's preintegration carries its bias Jacobians):
//
//   H_{k+1} = A_k H_k + B_k C_k,   C_k = d(dp_k, dphi_k)/dxi * dxi'/dc
//
// so that an estimator can refine c without integrating again: delta(c) ~ delta(c0) + H (c - c0).
#pragma once

#include <Eigen/Core>
#include <deque>
#include <string>

#include "rvwo/edges/se2.h"

namespace rvwo {

// Noise of one odometry reading, as densities over the motion it covers. Settings keys in [].
struct WheelNoise {
  // Robot-odometry pose input: random-walk densities.
  double sigma_x = 0.02;      // m/sqrt(m): along-track position, per sqrt(metre travelled) [Odometry.NoiseX]
  double sigma_y = 0.01;      // m/sqrt(m): cross-track (skid), per sqrt(metre travelled) [Odometry.NoiseY]
  double sigma_phi = 0.02;    // rad/sqrt(rad): heading, per sqrt(radian turned) [Odometry.NoiseRot]
  double sigma_phi_s = 0.01;  // rad/sqrt(m): heading, per sqrt(metre travelled) [Odometry.NoiseRotPerMetre]
  // Wheel-encoder input: each wheel's angle, per sqrt(radian of wheel rotation); the increment's
  // covariance follows from the differential-drive model's Jacobian. sigma_y is added as skid.
  double sigma_wheel = 0.01;  // rad/sqrt(rad) [Odometry.NoiseWheel]
  // Floor, so that a robot at rest keeps a finite information: per sqrt(second).
  double floor_p = 1e-3;    // m/sqrt(s) [Odometry.NoiseFloorP]
  double floor_phi = 1e-3;  // rad/sqrt(s) [Odometry.NoiseFloorRot]

  // Throws std::invalid_argument naming the key of a negative or non-finite density.
  void validate() const;
  // Covariance of a pose-odometry increment covering ds metres, dphi radians in dt seconds.
  Eigen::Matrix3d poseReadingCovariance(double ds, double dphi, double dt) const;
};

// Differential drive: wheel radii and track width, metres.
struct DiffDriveParams {
  double radius_left = 0.1;
  double radius_right = 0.1;
  double track = 0.5;
  void validate() const;
};

// The odometry's calibration correction c = (c_s, c_w, c_k): distance scale, turn scale (both
// relative), curvature bias (rad/m). Zero: the nominal odometry.
using WheelCalibration = Eigen::Vector3d;

// The twist correction dxi'/dc at xi (see the header comment).
Eigen::Matrix3d calibrationTwistJacobian(const Eigen::Vector3d& xi);
// d(t, phi)/d(v_x, v_y, w) of exp(xi) = (V(w) v, w), SE(2)'s exponential.
Eigen::Matrix3d se2ExpJacobian(const Eigen::Vector3d& xi);

// The preintegrated motion of the body between two times.
struct WheelDelta {
  double t0 = 0.0, t1 = 0.0;                                // s
  Eigen::Vector2d dp = Eigen::Vector2d::Zero();             // m, in the body frame at t0
  double dphi = 0.0;                                        // rad, not wrapped (a full turn stays 2 pi)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();     // of (dp, dphi)
  double distance = 0.0;                                    // m travelled (sum of |ds|)
  double rotation = 0.0;                                    // rad turned (sum of |dphi|)
  WheelCalibration calibration = WheelCalibration::Zero();  // c it was integrated with
  Eigen::Matrix3d d_calibration = Eigen::Matrix3d::Zero();  // d(dp, dphi)/dc there
  SE2 pose() const { return SE2(dp, dphi); }                // T_b0_b1
  // (dp, dphi) at calibration c, to first order from the one integrated.
  Eigen::Vector3d at(const WheelCalibration& c) const {
    return Eigen::Vector3d(dp.x(), dp.y(), dphi) + d_calibration * (c - calibration);
  }
  // The same delta at calibration c: (dp, dphi) moved to at(c), the covariance and the Jacobian
  // kept (c moves them by second-order terms only), so that deltas integrated with different
  // calibrations can be composed.
  WheelDelta recalibrated(const WheelCalibration& c) const;
};

// The motion over [a.t0, b.t1] from two deltas that meet (a.t1 == b.t0) at one calibration: as
// if the accumulator had gone on from a's sums through b's readings (eqs. 11 to 13, b one step):
//
//   dp = dp_a + R(dphi_a) dp_b,   dphi = dphi_a + dphi_b,
//   Sigma = A Sigma_a A^T + B Sigma_b B^T,   H = A H_a + B H_b,
//   A = [[I2, J R(dphi_a) dp_b], [0, 1]],    B = [[R(dphi_a), 0], [0, 1]].
//
// Exact (to rounding) when a.t1 is a reading's time; inside a reading, integrate() gives each
// part its share of the reading's noise, which differs from the whole's by the lever arm of the
// second part (a few per cent of the covariance for a reading at 30 Hz or faster). A host can so
// keep one delta per keyframe instead of the readings. Throws std::invalid_argument when the two
// do not meet or were integrated with different calibrations.
WheelDelta compose(const WheelDelta& a, const WheelDelta& b);

// The accumulator of eqs. 11 to 13, frame-agnostic: it integrates whatever increments it is given.
class WheelPreintegrator {
 public:
  void reset() { *this = WheelPreintegrator(); }
  // One increment (dp, dphi) in the current body frame with its covariance Sigma_n and its
  // Jacobian C_k w.r.t. the calibration (zero: none). Optional outputs: the step Jacobians A_k and B_k.
  void integrate(const Eigen::Vector2d& dp, double dphi, const Eigen::Matrix3d& sigma_n, Eigen::Matrix3d* A = nullptr,
                 Eigen::Matrix3d* B = nullptr, const Eigen::Matrix3d& C = Eigen::Matrix3d::Zero());
  const Eigen::Vector2d& dp() const { return dp_; }
  double dphi() const { return dphi_; }
  const Eigen::Matrix3d& covariance() const { return cov_; }
  const Eigen::Matrix3d& calibrationJacobian() const { return H_; }  // d(dp, dphi)/dc

 private:
  Eigen::Vector2d dp_ = Eigen::Vector2d::Zero();
  double dphi_ = 0.0;
  Eigen::Matrix3d cov_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d H_ = Eigen::Matrix3d::Zero();
};

// A time-stamped stream of odometry at any rate, integrated between any two times. One input
// kind per stream: the robot's own odometry poses, wheel angles, or wheel speeds. Increments are
// measured in the odometry frame o, mounted at T_b_o on the body; results are in the body frame.
class WheelOdometry {
 public:
  explicit WheelOdometry(const WheelNoise& noise = {}, const SE2& T_b_o = SE2());

  // Odometry pose of frame o in the odometry's world at time t (MRPT CObservationOdometry,
  // OpenLORIS odom.txt). Throws std::invalid_argument on NaN or a time not after the last one.
  void addPose(double t, const SE2& T_odom_o);
  // Cumulative wheel angles, rad (ticks * 2 pi / ticks_per_revolution).
  void addWheelAngles(double t, double q_left, double q_right, const DiffDriveParams& drive);
  // Wheel angular speeds, rad/s; integrated with the trapezoid rule between readings.
  void addWheelSpeeds(double t, double w_left, double w_right, const DiffDriveParams& drive);

  bool empty() const { return segments_.empty(); }
  double firstTime() const;  // of the first reading
  double lastTime() const;   // of the last reading
  // Motion of the body between t0 and t1, firstTime() <= t0 <= t1 <= lastTime(), every reading
  // corrected by the calibration c; a reading that straddles t0 or t1 is split along its
  // constant-twist arc. Throws std::out_of_range otherwise.
  WheelDelta integrate(double t0, double t1, const WheelCalibration& c = WheelCalibration::Zero()) const;
  // T_w_b at t1 predicted from T_w_b at t0 (for tracking).
  SE2 predict(const SE2& T_w_b0, double t0, double t1) const { return T_w_b0 * integrate(t0, t1).pose(); }
  // Forget the readings that end before t (what leaves the window stops costing).
  void dropBefore(double t);

 private:
  enum class Input { kNone, kPose, kWheelAngles, kWheelSpeeds };
  struct Segment {
    double t0, t1;
    SE2 increment;            // T_o(t0)_o(t1)
    Eigen::Vector3d xi;       // its twist, log(increment)
    Eigen::Matrix3d sigma_n;  // of (dp, dphi)
    double ds, dphi_abs;      // m, rad: |motion| covered
  };
  void checkReading(double t, Input kind, std::initializer_list<double> values);
  void pushWheelIncrement(double t, double dq_left, double dq_right, const DiffDriveParams& drive);

  WheelNoise noise_;
  SE2 T_b_o_;
  Input input_ = Input::kNone;
  std::deque<Segment> segments_;
  double last_t_ = 0.0;
  bool has_last_ = false;
  SE2 last_pose_;
  double last_a_ = 0.0, last_b_ = 0.0;  // last wheel angles or speeds
};

}  // namespace rvwo
