// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Pose-only optimisation of one frame in 6-DoF, for a camera without wheels: the camera pose
// T_c_w that best explains the frame's matches to known landmarks, each weighed by its landmark's
// Barron kernel (eq. 7; alpha -inf: rejected by its labels) or, as ORB-SLAM does, by Huber. What
// the ORB-SLAM3 plugin runs in place of Optimizer::PoseOptimization when the settings give no
// odometry (`Odometry.Input: "none"`): TUM RGB-D's hand-held sequences, the paper's Table I.
//
// optimisePlanarPose's pattern on 6 unknowns: `rounds` rounds of at most `iterations`
// Gauss-Newton steps T_c_w <- (Exp(omega) R_c_w, Exp(omega) t_c_w + v), each match classified
// against its chi2 gate (chi2Gate) after each round; a rejected match may come back in a later
// round. The residual of a match is z - h(T_c_w P_w) over sigma_px on each coordinate, h the
// camera's projection and, stereo, u_R = u - bf / z (ORB-SLAM3's edges); there is no plane to
// leave, so no out-of-plane inflation.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "rvwo/edges/camera.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo {

struct SpatialPoseOptions {
  bool huber = false;         // Huber at the gate's root instead of each landmark's Barron kernel
  double barron_scale = 1.0;  // Barron scale c in units of the gate's root (as PlanarPoseOptions)
  int rounds = 4;
  int iterations = 10;  // Gauss-Newton steps a round at most (stops earlier on a step < 1 um, 0.1 urad)
};

struct SpatialPoseResult {
  int inliers = 0;            // usable matches within the gate at the final pose
  std::vector<char> inlier;   // per observation
  std::vector<double> error;  // whitened error sqrt(chi2) at the final pose (1e9 squared when it does
                              // not project): what eq. 6 turns into an outlier probability
};

// The whitened residual of one observation at T_c_w (observation's P_w in T_c_w's world; P_c =
// T_c_w P_w), 2 rows (mono) or 3 (stereo, bf > 0 px m), and optionally its Jacobian in (omega, v)
// of the update above, 6 columns. False when the landmark is not in front of the camera.
bool spatialResidual(const CameraModel& camera, double bf, const PoseObservation& o, const Eigen::Isometry3d& T_c_w,
                     Eigen::Vector3d* r, Eigen::Matrix<double, 3, 6>* J = nullptr);

// Optimises *T_c_w (in: the prediction; out: the estimate). Stereo observations need bf > 0.
SpatialPoseResult optimiseSpatialPose(const CameraModel& camera, double bf,
                                      const std::vector<PoseObservation>& observations,
                                      const SpatialPoseOptions& options, Eigen::Isometry3d* T_c_w);

}  // namespace rvwo
