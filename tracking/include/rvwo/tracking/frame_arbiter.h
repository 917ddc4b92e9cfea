// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The wheels against vision, frame by frame: the one object both hosts (RVWO's estimator, the
// ORB-SLAM3 plugin) give a frame's matches and wheel delta. decide() solves the pose with the wheel
// edge (optimisePlanarPose), judges whether vision alone overrules the wheels (decideSlip, with the
// creep or stall test over vision alone's own recent poses), else whether the pose goes back to the
// wheels (solveFromTheWheels, the wheel gate), and keeps what the next frame's decision needs.
// docs/estimator.md lists the rules; docs/decisions/0011 the bars where the hosts still differ.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <functional>
#include <optional>
#include <vector>

#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/tracking/options.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo {

// Which test watches vision alone's own track for wheels that drift over a stretch while each
// frame's claim fits (vision alone is then solved every frame).
enum class DriftTest {
  kNone,
  kCreep,  // wheelsCreep over the last kCreepStretch (stereo, RGB-D: the ORB-SLAM3 plugin)
  kStall,  // wheelsStall over the last kStallStretch, kStallFrames in a row (mono: the estimator)
};

// The bars and tests a host runs. Counts are of trusted inliers (landmarks no label has called
// dynamic); docs/decisions/0011 gives both hosts' values where they differ.
struct ArbiterOptions {
  int min_inliers = 20;                // trusted inliers that place a frame (Tracking.MinInliers)
  int after_blind = 3;                 // x min_inliers, for the first frame back from the wheels alone (plugin 1)
  int overrule = 1;                    // x the frame's bar, for vision alone to go on with a slip (plugin 2)
  double slip_start = 2.0;             // x min_inliers, for vision alone to start a slip (Tracking.SlipMinInliers)
  bool check_slip = true;              // vision alone may overrule the wheels (Tracking.SlipCheck)
  bool judge_every_frame = false;      // judge the slip every frame, not only where worth checking (plugin true)
  bool bound_miss_after_slip = true;   // after a slip, vision alone misses the claim by a skid at most (plugin false)
  DriftTest drift = DriftTest::kNone;  // estimator: kStall for mono; plugin: kCreep
  bool wheel_gate = true;              // the wheel gate (Tracking.WheelGate; adaptive kernel, depth)
  PlanarPoseOptions pose;              // the solves'

  // Each host's bars and tests where they still differ (docs/decisions/0011); apply() then sets
  // what the settings give.
  static ArbiterOptions estimator(bool mono);  // RVWO's estimator: mono runs the stall test
  static ArbiterOptions orbslam3();            // the ORB-SLAM3 plugin
  // min_inliers, slip_start, check_slip and pose's kernel scale and noise from the settings; the
  // wheel gate stays off where the preset has it off.
  ArbiterOptions& apply(const TrackingOptions& t);
};

// One frame as the host sees it.
struct FrameEvidence {
  double t = 0.0;                        // s, the frame's time
  const Se2XyzMonoEdge* mono = nullptr;  // the camera's edges; stereo null without depth
  const Se2XyzStereoEdge* stereo = nullptr;
  std::vector<PoseObservation> observations;          // the frame's matches
  std::vector<char> trusted;                          // per observation: counts as vision's evidence
  std::optional<WheelDelta> wheels;                   // from x_prev to this frame; none: vision alone
  Eigen::Vector3d x_prev = Eigen::Vector3d::Zero();   // x_w_b where the delta starts
  double t_prev = 0.0;                                // s, its time
  Eigen::Vector3d x_guess = Eigen::Vector3d::Zero();  // where the solve starts
  bool after_blind = false;                           // the frame before was carried by the wheels alone
  // The wheels over [t0, t1] (the drift tests' stretches); none where the readings do not reach.
  std::function<std::optional<WheelDelta>(double t0, double t1)> wheels_between;
};

struct FrameDecision {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // x_w_b, the frame's pose
  PlanarPoseResult result;                      // inliers, whitened errors and information at x
  int candidates = 0;                           // trusted observations
  int to_place = 0;                             // trusted inliers that place this frame (its bar)
  int placed = 0;                               // trusted inliers at x
  int vision_alone_placed = -1;                 // trusted inliers of vision alone, when the slip was judged
  bool strained = false;                        // the pose solved with the wheel edge strains it (wheelEdgeStrained)
  bool slip = false;                            // vision alone overruled the wheels: x is its pose
  bool spin = false;                            // ... and the robot about stood (slipIsSpin)
  bool gated = false;                           // the wheel gate put the pose back on the wheels
  double slip_from = 0.0;                       // s: where the slip starts (a creep: its stretch's start)
  bool visual() const { return placed >= to_place; }
};

class FrameArbiter {
 public:
  // Vision alone's track for the creep test (seconds) and the stall test (seconds, frames in a row).
  static constexpr double kCreepStretch = 0.5;  // 8 mm a frame of creep adds up in 3 to 6 frames
  static constexpr double kStallStretch = 0.2;  // 3 cm (kStallTravel) at 0.15 m/s
  static constexpr int kStallFrames = 5;        // a bump or a walker pulls vision alone off for one or two stretches
  // A stall-tested slip that starts farther back than the wheels' claim (missBeyondTheClaim) needs
  // this many times min_inliers (docs/decisions/0009).
  static constexpr int kBeyondTheClaimStart = 5;

  explicit FrameArbiter(const ArbiterOptions& options = {});
  const ArbiterOptions& options() const { return options_; }

  // The frame's pose and the wheels-against-vision decision. A frame without observations ends a
  // slip (and the stall test's track); the pose is then x_guess.
  FrameDecision decide(const FrameEvidence& e);

  bool slipping() const { return slipping_; }  // the last decision was a slip

 private:
  struct Seen {
    double t;
    Eigen::Vector3d x;
    Eigen::Matrix3d information;
  };
  struct VisionAlone {
    Eigen::Vector3d x;
    PlanarPoseResult result;
    int placed = 0;
  };
  VisionAlone solveVisionAlone(const FrameEvidence& e) const;
  bool creeps(const FrameEvidence& e, const VisionAlone& v, int bar, int candidates, double* slip_from);
  bool stalls(const FrameEvidence& e, const VisionAlone& v, int bar);
  void judgeSlip(const FrameEvidence& e, const WheelDelta& wheels, bool was_slipping, FrameDecision* d);
  void gate(const FrameEvidence& e, const WheelEdge& edge, FrameDecision* d) const;

  ArbiterOptions options_;
  bool slipping_ = false;
  std::deque<Seen> track_;  // vision alone's recent poses, for the drift test
  int stall_run_ = 0;       // stretches in a row the stall test found stalled
};

// Trusted inliers among the inliers.
int countTrusted(const std::vector<char>& inlier, const std::vector<char>& trusted);

}  // namespace rvwo
