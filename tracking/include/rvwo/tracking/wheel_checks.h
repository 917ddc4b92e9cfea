// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The wheels against vision: the tests that decide, frame by frame, whether the wheel edge is to
// be trusted or vision alone overrules it (a slip), and whether wheels that agree frame by frame
// drift over a stretch (a creep, a stall). Each compares the wheels' preintegrated delta (eqs. 11
// to 13) with the motion vision alone found over it; the tolerances are the delta's own 3 sigma
// plus floors for what neither noise holds. Used by RVWO's estimator and the ORB-SLAM3 plugin.
#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "rvwo/edges/se2.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/edges/wheel_preintegration.h"

namespace rvwo {

// A wheel edge's gate (3 DoF, 99.9 %).
constexpr double kChi2WheelOutlier = 16.27;

// Whether the wheel edge from x_prev to x lies beyond its gate: vision held the pose where the
// wheels' claim does not fit (a strained compromise).
bool wheelEdgeStrained(const WheelEdge& edge, const Eigen::Vector3d& x_prev, const Eigen::Vector3d& x);

// What the wheels' noise allows between them and vision over one delta: 3 sigma + 5 mm / 5 mrad.
struct WheelTolerance {
  double translation, rotation;  // m, rad
  explicit WheelTolerance(const WheelDelta& wheels);
};

// A slip as wheels make one: they claimed motion the robot did not make (spinning or skidding on
// the spot). So vision alone went no farther along the wheels' direction than they claimed, and
// turned no more their way (beyond their 3 sigma and 5 mm / 5 mrad a frame), and the difference
// stays small (the frames before took the wheels' side only while vision could not tell). It may
// lie sideways and turn against them: the miss is measured from the last pose, and includes what
// those frames took; sideways no farther than 3 cm and a skid at 0.3 m/s over the delta (beyond
// the tolerance). Among walkers, vision alone is pulled anywhere, often further or turning
// more than the wheels: without this test 56 frames of the 90 s dynamic scenario took it, one 35 cm
// off the robot. T_b0_b1_vision: the motion vision alone found over the wheels' delta.
bool looksLikeSlip(const WheelDelta& wheels, const SE2& T_b0_b1_vision);

// A slip frame where the robot about stood while the wheels went on (spinning in place): vision
// alone saw no more than kSpinSeen of the travel they claimed and of their turn, give or take
// kSpinSlack. A skid (the robot moving, only not as claimed) is not one. Local BA leaves a wheel
// edge across such frames out of its first round (the estimator's Mapper::addWheelEdges).
constexpr double kSpinSeen = 0.5;     // of the claim
constexpr double kSpinSlack = 0.002;  // m and rad
bool slipIsSpin(const WheelDelta& wheels, const SE2& T_b0_b1_vision);

// Whether vision's motion differs from the wheels' beyond their tolerance.
bool wheelsDisagree(const WheelDelta& wheels, const SE2& T_b0_b1_vision);

// Whether vision alone misses the wheels' claim by more than the claim itself, their tolerance and
// a skid (0.3 m/s over the delta): more than a slip that starts with this delta explains (the robot
// stood, or skidded), so the frames before must have taken the wheels' side.
bool missBeyondTheClaim(const WheelDelta& wheels, const SE2& T_b0_b1_vision);

// Where a relocalisation may put the robot after a blind stretch: on the way the wheels claimed
// over it, as a slip leaves it (the robot went part of that way, s in [0, 1] of it, and stood
// while the wheels went on), within their tolerance and kClaimedWaySlack, its heading the claim's
// at that point within their tolerance and the same slack. The way is taken as the claim's
// constant-twist arc, exp(s log(T_claim)) (the delta keeps no more of it); a spin on the spot is
// s = 0. Among walkers no label marks, relocalisation matched walkers to their own landmarks
// made elsewhere: the ONNX network threaded on `dynamic` (it misses the simulator's walkers), 20
// of the 22 relocalisations in three runs that a plain bound on the miss let through
// (missBeyondTheClaim, which allows a skid at 0.3 m/s over the whole stretch) were 3.5-45 cm and
// up to 0.12 rad off, where the claim was right to 8 mm. T_b0_b1_vision: from the last frame
// vision placed with the wheels to the relocalised one.
constexpr double kClaimedWaySlack = 0.03;  // m and rad
bool onTheClaimedWay(const WheelDelta& wheels, const SE2& T_b0_b1_vision);

// Wheels that creep: each frame's claim within their tolerance (a few millimetres too many, as a
// slow skid makes), but over a stretch the robot went a clearly shortened way along the arc they
// claimed (slowed or stopped while they went on): vision alone's motion is s times their claim,
// s below 1 beyond the noise, and off that line no more than the noise allows (walkers pull vision
// alone sideways or turning against the travel: among them, without this, the dynamic scenario
// took 136 frames as slips in ORB-SLAM3 and its ATE doubled). Vision alone's own poses at the
// stretch's ends, x0 and x1, each placed against the map with its information
// (PlanarPoseResult::information), so that the fused poses' drift between them does not enter.
// The noise: the wheels' covariance, both poses', and what neither holds (the map's errors and the
// wheels' calibration: sigma 5 mm / 5 mrad, and 3 % of the travel and 5 % of the turn claimed);
// gates at 99.9 %. Frame by frame the fused pose follows such wheels: each frame's edge (1 mm
// sigma) outweighs a sub-pixel pull, and the drift adds up (the stereo slip scenario: 5 cm before
// the edge was strained; WheelsThatCreepLoseToVision).
bool wheelsCreep(const WheelDelta& wheels, const Eigen::Vector3d& x0, const Eigen::Matrix3d& information0,
                 const Eigen::Vector3d& x1, const Eigen::Matrix3d& information1);

// The part of the wheels' claim vision alone saw (1: all of it, 0: none, negative: the other
// way): along the claimed travel, or of the claimed turn, whichever the claim holds more of against
// what wheelsStall judges (kStallTravel, kStallTurn); 1 for no claim at all.
double stallSeen(const WheelDelta& claim, const SE2& T_b0_b1_vision);

// Wheels that stall (mono's creep test): over a stretch of a few frames the wheels claimed a
// travel or a turn well beyond what one mono frame's noise hides (kStallTravel, kStallTurn), and
// vision alone's own poses at the stretch's ends saw less than half of it (stallSeen: the robot
// stood or crawled while the wheels went on) and no more than kStallBack of it backwards (walkers
// and bumps pull vision alone both ways; a stalled robot stands still). Mono's vision weighs
// little along its optical axis against the wheel edge, so the fused pose follows such wheels
// frame by frame and the counts of a frame cannot tell: a 1 s slip under a static mono scene was
// caught 0.6 s late, 15 cm on. Its pose noise and the map's scale (the wheels', to a few percent)
// are too large for wheelsCreep's 3 % bar; a stall is the far end of a creep, where they do not
// matter. T_b0_b1_vision: vision alone's motion over the stretch the wheels' delta covers.
constexpr double kStallTravel = 0.03, kStallTurn = 0.05;  // m, rad: the least claim judged
constexpr double kStallRatio = 0.5, kStallBack = 0.3;     // of the claim
bool wheelsStall(const WheelDelta& stretch, const SE2& T_b0_b1_vision);

// Everything the slip decision weighs for one frame: the pose solved with the wheel edge (fused)
// and again without it (vision alone, started at the edge's first pose).
struct SlipEvidence {
  const WheelDelta* wheels = nullptr;  // the wheel edge's delta
  // The two solves' motions over the delta.
  SE2 T_b0_b1_fused, T_b0_b1_vision;
  // Their inliers, counted as the caller counts them (the estimator: only landmarks no label has
  // called dynamic), and the candidates counted alike (what could have been inliers).
  int fused_inliers = 0, vision_inliers = 0, candidates = 0;
  bool strained = false;      // the wheel edge beyond kChi2WheelOutlier at the fused pose
  bool creeping = false;      // wheelsCreep over the last stretch vision alone tracked
  bool stalled = false;       // mono: wheelsStall over the last stretches vision alone tracked
  bool was_slipping = false;  // the last decision was a slip (the previous frame's; in ORB-SLAM3,
                              // which solves a frame twice, the frame's first solve's)
  // Vision-alone inliers a slip needs to start, and to go on (at least what places a frame).
  int min_to_start = 0, min_to_go_on = 0;
  // The delta starts at a pose vision alone placed (the previous frame slipped): no frame before
  // took the wheels' side, so vision alone may miss their claim by no more than the claim itself,
  // the tolerance and a skid's 0.3 m/s.
  bool from_vision_alone = false;
};

// Whether the frame is worth solving again without the wheels: a slip goes on, the wheel edge is
// strained, or the fused pose left many matches unexplained.
bool slipWorthChecking(bool was_slipping, bool strained, std::size_t matches, int fused_inliers);

// Whether vision alone overrules the wheels for this frame. A slip starts when vision alone explains
// clearly more (or, the wheel edge strained, noticeably more, or more while both motions lie
// beyond the wheels' tolerance), nearly all candidates, and in the way a slip would (looksLikeSlip).
// Once slipping, vision alone stays in charge while it explains about as much and the wheels go on
// claiming motion it does not see (beyond their tolerance or their gate): decided afresh each frame,
// the wheel prior pulled the pose a little every frame until vision alone won again, a sawtooth of
// up to 0.4 m. A slow skid (3 mm a frame) or a slow spin on the spot pulls the fused pose only a
// little each frame, never far enough to cost 30 % of the inliers; among walkers vision alone gained
// at most 4 % (measured in the estimator). Creeping wheels start a slip, or keep one going, when
// vision alone explains about as much as the fused pose (98 %): the creep costs no inliers.
// Stalled wheels (mono) do too, when vision alone also explains nearly every candidate
// (kStallExplained): where mono's vision alone, confidently wrong on a map a slip or bumps bent,
// saw the robot stand while it drove (threaded mono combined), it left 7 to 21 % of them out; in
// a stall under a static scene 1 to 3 %.
constexpr double kStallExplained = 0.95;
bool decideSlip(const SlipEvidence& e);

}  // namespace rvwo
