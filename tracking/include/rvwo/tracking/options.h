// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The tracking core's options, one settings namespace for both hosts (RVWO's estimator and the
// ORB-SLAM3 plugin): rvwo::readTrackingOptions (rvwo/settings/settings.h) reads the keys named
// beside each member; decisions cited are docs/decisions/NNNN. Where a host's default differs, the
// host says so (docs/decisions/0011). Plain C++11: the ORB-SLAM3 plugin's public header holds one.
#pragma once

namespace rvwo {

struct OutOfPlaneNoise;  // rvwo/edges/se2_xyz_edge.h

struct TrackingOptions {
  int min_inliers = 20;  // trusted inliers that place a frame (Tracking.MinInliers; ORB-SLAM3 plugin 30)
  double slip_min_inliers =
      2.0;                 // x min_inliers behind vision alone to start a slip (Tracking.SlipMinInliers; decision 0009)
  double slip_hold = 2.0;  // s a blind frame after a slip holds the pose (Tracking.SlipHold; estimator; decision 0009)
  int slip_hold_min_frames =
      3;                        // frames a slip lasts before a hold (Tracking.SlipHoldMinFrames; estimator; 0003, 0009)
  double trusted_max_ps = 0.1;  // P_s (eq. 4) under which a landmark is trusted (Tracking.TrustedMaxPs)
  bool slip_check = true;       // vision alone may overrule the wheels (Tracking.SlipCheck: 1 | 0)
  bool wheel_gate = true;       // the wheel gate, adaptive kernel with depth (Tracking.WheelGate: 1 | 0; decision 0002)
  double barron_scale = 2.0;    // Barron's c, in units of the chi2 gate's root (Tracking.BarronScale; decision 0008)
  double sigma_z = 0.01;        // m: the body's height off its floor (Tracking.SigmaZ)
  double sigma_rollpitch = 0.01;  // rad: its roll and pitch (Tracking.SigmaRollPitch)

  // Eq. 10's noise from sigma_z and sigma_rollpitch.
  OutOfPlaneNoise outOfPlane() const;
  // Throws std::invalid_argument naming the key of the first value out of its range.
  void validate() const;
};

}  // namespace rvwo
