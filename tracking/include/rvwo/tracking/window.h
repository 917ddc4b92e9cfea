// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The window bundle adjustment on SE(2): what local mapping solves after each keyframe, in RVWO's
// estimator and in the ORB-SLAM3 plugin alike. Each host fills a WindowProblem from its own map
// and writes the WindowSolution back; where the hosts still differ, WindowOptions names it
// (docs/decisions/0010).
//
// Variables: the free keyframes' planar poses x_w_b = (x, y, theta), the points P_w, and the
// odometry's calibration c (docs/maths.md section 4) when the window has wheel edges that may
// teach it. Terms:
//   - an SE(2)-XYZ edge per observation (eqs. 8 to 10), under its point's Barron kernel (eq. 7;
//     a rejected point, alpha -inf, stays where it is) or Huber, the out-of-plane covariance taken
//     at the starting state;
//   - a wheel edge per pair of keyframes the host gives (eq. 14): quadratic and calibrated; under
//     Huber and not calibrated across a slip tracking caught; left out of the first round across a
//     spin, and back in the second (Huber) only where the first round's keyframes agree with it
//     (docs/decisions/0003);
//   - the calibration's priors (ceres_adapters::WheelCalibrationEstimate::addPriors).
//
// Two rounds (ORB-SLAM's two-stage local BA) when anything may change between them, one
// otherwise. Between the rounds: spin edges come back where they agree; a wheel edge vision
// contradicts the way a slip does (clearly more travel along the wheels' own direction, or more
// turn their way, beyond the 99.9 % gate) may leave; the calibration is held at its last value
// unless every quadratic wheel edge lies within its gate; observations beyond the chi2 gate may
// leave, and points left with fewer than min_views edges with them.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "rvwo/ceres/costs.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo {

struct WindowKeyFrame {
  Eigen::Vector3d x_w_b = Eigen::Vector3d::Zero();  // (x, y, theta), the start
  double t = 0.0;                                   // s
  bool fixed = false;                               // held: carries the gauge (and the wheels into the window)
};

struct WindowPoint {
  Eigen::Vector3d P_w = Eigen::Vector3d::Zero();  // the start
  double alpha = 1.0;                             // Barron shape (eq. 7); -inf: rejected, not solved
};

struct WindowObservation {
  int keyframe = 0, point = 0;
  Eigen::Vector3d z = Eigen::Vector3d::Zero();  // (u, v, u_R) [px]; u_R used only when stereo
  bool stereo = false;                          // a right-image (or depth) coordinate
  double sigma_px = 1.0;                        // keypoint noise [px]
};

// The wheels between keyframes a and b (a before b in time).
struct WindowWheelEdge {
  int a = 0, b = 0;
  WheelDelta delta;      // integrated with the calibration the problem starts from
  bool slipped = false;  // across a slip tracking caught: Huber, not calibrated
  bool spin = false;     // across a spin or a hold: out of the first round (docs/decisions/0003)
};

struct WindowProblem {
  std::vector<WindowKeyFrame> keyframes;
  std::vector<WindowPoint> points;
  std::vector<WindowObservation> observations;
  std::vector<WindowWheelEdge> wheels;
  ceres_adapters::WheelCalibrationEstimate calibration;  // the odometry's, before this BA
};

// One line an option: its unit and its settings key where a host reads it from one.
struct WindowOptions {
  bool huber = false;            // Huber at the gate's root for every observation (--kernel huber)
  double barron_scale = 2.0;     // Barron's c, in units of the gate's root (Tracking.BarronScale; docs/decisions/0008)
  OutOfPlaneNoise out_of_plane;  // m, rad^2 (Tracking.SigmaZ, Tracking.SigmaRollPitch)
  int min_views = 1;             // edges a point needs to be solved (mono: 2, for its depth)
  bool outliers_leave = true;    // observations beyond the gate leave the second round
  bool drop_slipping_wheel_edges = true;               // wheel edges that vision contradicts like a slip leave
  double slipped_wheel_chi2 = kChi2Stereo;             // Huber threshold (chi2) of a wheel edge across a slip or spin
  bool calibrate = true;                               // c is a variable (Odometry.Calibrate)
  bool hold_distance_scale = false;                    // c's distance scale held (mono: the wheels are its metric)
  Eigen::Vector3d calibration_sigma{0.05, 0.05, 0.2};  // prior around zero: scale, turn scale, rad/m
  Eigen::Vector3d calibration_step{0.003, 0.003, 0.005};  // random walk per calibration_period (docs/decisions/0001)
  double calibration_period = 0.5;                        // s
  bool needs_a_fixed_keyframe = false;  // nothing is solved unless one is in the problem (ORB-SLAM3's rule)
  int first_round_iterations = 5;
  int second_round_iterations = 10;  // also the one round's, when there is one
  const bool* stop = nullptr;        // the host asks the solve to end (ORB-SLAM3's abort flag); may be null
};

struct WindowSolution {
  std::vector<Eigen::Vector3d> x_w_b;  // per keyframe (fixed ones and those not in the problem as given)
  std::vector<Eigen::Vector3d> P_w;    // per point (those not solved as given, or as the first round left them)
  std::vector<char> placed;            // per keyframe: free and in the problem
  std::vector<char> solved;            // per point: in the problem to the end
  std::vector<double> chi2;            // per observation: whitened chi2 at the solution, 1e9 if it does not project
  std::vector<char> outlier;           // per observation: beyond its chi2 gate, or not projecting
  bool ran = false;                    // something was solved
  bool usable = true;                  // the solve's result may be written back (true when nothing ran)
  WheelCalibration calibration = WheelCalibration::Zero();  // c after the BA (as before unless calibrated)
  bool calibrated = false;  // c was free to the end, the wheels agreeing with the window
  double newest_t = 0.0;    // s: the newest keyframe's time, the one a learnt c is dated with
  Eigen::Matrix3d calibration_information = Eigen::Matrix3d::Zero();  // of the priors on c
  int wheel_edges = 0;                                                // in the problem at the end
  int wheel_edges_dropped = 0;                                        // found slipping after the first round
};

// Solves the window. stereo may be null when no observation is stereo.
WindowSolution solveWindow(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, const WindowProblem& problem,
                           const WindowOptions& options);

}  // namespace rvwo
