// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Pose-only optimisation of one frame on SE(2): the robot pose x_w_b = (x, y, theta) that best
// explains the frame's matches to known landmarks (SE(2)-XYZ edges, eqs. 8 to 10, each weighed
// by its landmark's Barron kernel, eq. 7), optionally tied to the previous frame's pose by the
// wheels' preintegrated motion (wheel edge, eq. 14). What tracking runs for every frame, in RVWO's
// estimator and in the ORB-SLAM3 plugin alike.
//
// Iteratively reweighted Gauss-Newton on 3 unknowns, in ORB-SLAM's pattern of `rounds` rounds of
// `iterations` steps: after each round every match is classified against the chi2 gate at the
// new pose (5.991 for 2 DoF, 7.815 for 3: 95 %), outliers leave the next round and may come back
// in a later one. Each round re-linearises the out-of-plane covariance (eq. 10) at its start.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "rvwo/edges/se2.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_edge.h"

namespace rvwo {

// ORB-SLAM's gates: chi2 quantiles at 95 % for 2 (u, v) and 3 (u, v, u_R) degrees of freedom.
constexpr double kChi2Mono = 5.991, kChi2Stereo = 7.815;
inline double chi2Gate(bool stereo) { return stereo ? kChi2Stereo : kChi2Mono; }

// One match of the frame: a landmark and the keypoint it was found at.
struct PoseObservation {
  Eigen::Vector3d P_w;      // landmark, planar world frame [m]
  Eigen::Vector3d z;        // (u, v, u_R) [px]; u_R used only when stereo
  bool stereo = false;      // a right-image (or depth) coordinate: 3-DoF residual
  double sigma_px = 1.0;    // keypoint noise [px] (pyramidSigma of its level)
  double alpha = 1.0;       // Barron shape of the landmark (eq. 7); -inf: rejected, never used
  bool usable = true;       // false: classified against the gate, never places the pose
  bool first_round = true;  // false: left out of the first round, classified after it like any
};

struct PlanarPoseOptions {
  // Huber (at the gate's root) instead of each landmark's Barron kernel: ORB-SLAM's own choice.
  bool huber = false;
  // Barron scale c in units of the gate's root (at alpha = 1 Barron then bends where Huber does).
  double barron_scale = 1.0;
  OutOfPlaneNoise out_of_plane;  // eq. 10
  int rounds = 4;
  int iterations = 10;  // Gauss-Newton steps a round at most (stops earlier on a step < 1 um)
};

// The wheel edge from the previous frame's pose x_prev (held fixed) to this frame's.
struct WheelPrior {
  const WheelEdge* edge = nullptr;
  Eigen::Vector3d x_prev = Eigen::Vector3d::Zero();
};

struct PlanarPoseResult {
  int inliers = 0;            // usable matches within the gate at the final pose
  std::vector<char> inlier;   // per observation
  std::vector<double> error;  // whitened error sqrt(chi2) at the final pose (1e9 squared when it
                              // does not project); what eq. 6 turns into an outlier probability
  // What the matches alone say of x: their Gauss-Newton information J^T W J (the wheel prior left
  // out) at the last step. Its inverse is the pose's covariance as far as pixel noise goes (the
  // landmarks taken as known).
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
};

// Optimises *x (in: the prediction; out: the estimate). stereo: the edge of 3-DoF observations,
// may be null when none is stereo. prior.edge null: vision alone.
PlanarPoseResult optimisePlanarPose(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo,
                                    const std::vector<PoseObservation>& observations, const WheelPrior& prior,
                                    const PlanarPoseOptions& options, Eigen::Vector3d* x);

// Squared whitened error of one observation at x (eq. 10's covariance at x); false when the
// landmark does not project.
bool whitenedChi2(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, const PoseObservation& o,
                  const Eigen::Vector3d& x, const OutOfPlaneNoise& out_of_plane, double* chi2);

// The wheel gate: the pose solved with the wheel edge strains it (wheelEdgeStrained) and vision
// alone did not win (no slip), so the wheels hold and what pulls against them is suspect: walkers
// no label marks drag the fused pose a few millimetres and milliradians a frame, each frame's
// edge starting where the last one was dragged. The pose is solved again from the wheels'
// prediction x_predicted, with the prior: its first round on the usable matches that prediction
// explains (within their gate there), its later rounds on any the new pose explains (kept out for
// good, they bent frames over a bumpy floor towards the wheels' jitter). counted: the matches
// that count towards min_agree (the host's trusted ones). Sets *x and returns true with the new
// result in *r, or returns false (both untouched) when fewer than min_agree counted matches agree.
bool solveFromTheWheels(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, std::vector<PoseObservation> obs,
                        const WheelPrior& prior, const PlanarPoseOptions& opt, const Eigen::Vector3d& x_predicted,
                        const std::vector<char>& counted, int min_agree, Eigen::Vector3d* x, PlanarPoseResult* r);

}  // namespace rvwo
