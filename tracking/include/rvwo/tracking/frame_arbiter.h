// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The wheels against vision, frame by frame: the one object both hosts (RVWO's estimator, the
// ORB-SLAM3 plugin) give a frame's matches and wheel delta. decide() solves the pose with the wheel
// edge (optimisePlanarPose), judges whether vision alone overrules the wheels (decideSlip, with the
// creep or stall test over vision alone's own recent poses), else whether the pose goes back to the
// wheels (solveFromTheWheels, the wheel gate), and keeps what the next frame's decision needs. A
// host that relocalises a blind frame asks believeRelocalisation(); one that holds the pose after
// a slip and doubts the wheels for its keyframes ends each frame with settle().
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
  kCreep,  // wheelsCreep over the last kCreepStretch (stereo, RGB-D: the plugin; the estimator with labels)
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
  DriftTest drift = DriftTest::kNone;  // estimator: kStall for mono (its host sets kCreep with labels); plugin: kCreep
  bool wheel_gate = true;              // the wheel gate (Tracking.WheelGate; adaptive kernel, depth)
  double hold = 2.0;                   // s a blind frame after a slip holds the pose (Tracking.SlipHold)
  int hold_min_frames = 3;             // slip frames in a row before a hold (Tracking.SlipHoldMinFrames)
  PlanarPoseOptions pose;              // the solves'

  // Each host's bars and tests where they still differ (docs/decisions/0011); apply() then sets
  // what the settings give.
  static ArbiterOptions estimator(bool mono);  // RVWO's estimator: mono runs the stall test
  static ArbiterOptions orbslam3();            // the ORB-SLAM3 plugin
  // min_inliers, slip_start, check_slip, the hold and pose's kernel scale and noise from the
  // settings; the wheel gate stays off where the preset has it off.
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
  // Most trusted landmarks agree on a pose of their own, away from the wheels' (as in a slip), yet
  // too few to place the frame: walkers cover most of the view.
  bool contradicts_wheels = false;
  bool visual() const { return placed >= to_place; }
};

// How a frame ends, once vision (decide, a relocalisation) has placed it or not.
struct FrameOutcome {
  bool held = false;            // blind right after a slip: the pose stays where vision left it
  bool wheels_doubted = false;  // blind, and a frame's landmarks contradicted the wheels within the hold
};

class FrameArbiter {
 public:
  // Vision alone's track for the creep test (seconds) and the stall test (seconds, frames in a row).
  static constexpr double kCreepStretch = 0.5;  // 8 mm a frame of creep adds up in 3 to 6 frames
  static constexpr double kCreepRecent = 0.25;  // ... and must show over this recent part too
  static constexpr double kStallStretch = 0.2;  // 3 cm (kStallTravel) at 0.15 m/s
  static constexpr int kStallFrames = 5;        // a bump or a walker pulls vision alone off for one or two stretches
  // A stall-tested slip that starts farther back than the wheels' claim (missBeyondTheClaim) needs
  // this many times min_inliers (docs/decisions/0009).
  static constexpr int kBeyondTheClaimStart = 5;
  // A relocalisation of a frame after a blind one, in min_inliers: believed alone (kRelocaliseAlone),
  // over a run of relocalisations that agree where each frame's wheel motion allows (kRelocaliseRun),
  // or off the wheels' way since vision's last frame (kRelocaliseAnywhere). Walkers covering most of
  // the view leave 20-50 static landmarks, each frame another set of them.
  static constexpr int kRelocaliseAlone = 3;
  static constexpr int kRelocaliseRun = 4;
  static constexpr int kRelocaliseAnywhere = 10;

  explicit FrameArbiter(const ArbiterOptions& options = {});
  const ArbiterOptions& options() const { return options_; }

  // The frame's pose and the wheels-against-vision decision. A frame without observations ends a
  // slip (and the stall test's track); the pose is then x_guess.
  FrameDecision decide(const FrameEvidence& e);

  // Whether the host's relocalisation of the frame decide() last saw (blind, after a blind one)
  // places it: at x with `placed` trusted inliers. on_the_wheels_way (asked only when it matters)
  // says whether x is where the wheels could have taken the robot since vision's last frame.
  bool believeRelocalisation(const Eigen::Vector3d& x, int placed, const std::function<bool()>& on_the_wheels_way);

  // The frame decide() last saw ends visual or not: held after a slip (blind within hold of a
  // slip of hold_min_frames or more, the blind stretch starting in it), and whether its
  // landmarks doubt the wheels (contradicts_wheels within hold, until vision places a frame).
  FrameOutcome settle(bool visual);

  bool slipping() const { return slipping_; }  // the last decision was a slip

  // Whether landmarks doubt the wheels at the frame decide() last saw: its own contradict them, or
  // a blind frame's did within hold before it, no frame placed by vision since.
  bool wheelsDoubted() const { return frame_.contradicts_wheels || frame_.t - doubted_t_ <= options_.hold; }

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

  // The frame decide() last saw, for believeRelocalisation and settle.
  struct Frame {
    double t = 0.0, t_prev = 0.0;
    std::optional<WheelDelta> wheels;
    bool was_slipping = false, contradicts_wheels = false;
  } frame_;
  double last_slip_t_ = -1e300;  // s: the last slip frame
  int slip_run_ = 0;             // slip frames in a row (a hold continues the run), up to the last one
  bool holding_ = false;         // the last frame was held after a slip
  double doubted_t_ = -1e300;    // s: the last blind frame whose landmarks contradicted the wheels
  struct RelocalisedRun {
    double t = -1e300;  // its last frame
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    int placed = 0;  // trusted inliers summed over the run
  } relocalised_;
};

// Trusted inliers among the inliers.
int countTrusted(const std::vector<char>& inlier, const std::vector<char>& trusted);

}  // namespace rvwo
