// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The wheels against vision: a slip is the wheels claiming motion vision did not see; it starts on
// clear evidence and goes on while the wheels still lie; a creep is the wheels' claim beyond both
// noises over a stretch; a spin is the robot standing while the wheels go on; a relocalisation is
// believed only on the way the wheels claimed; a stall is less than half the claim seen.
#include "rvwo/tracking/wheel_checks.h"

#include <gtest/gtest.h>

#include "rvwo/edges/se2.h"

namespace rvwo {
namespace {

TEST(WheelsAgainstVision, SlipIsWheelsClaimingMotionVisionDidNotSee) {
  WheelDelta d;
  d.dp << 0.10, 0.0;
  d.dphi = 0.05;
  d.covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();  // tolerance 3 sigma + 5 mm: 9.2 mm, 8 mrad
  // Agreement within the tolerance: neither disagreement nor a slip's evidence against them.
  EXPECT_FALSE(wheelsDisagree(d, SE2(0.095, 0.003, 0.046)));
  EXPECT_TRUE(wheelsDisagree(d, SE2(0.085, 0.0, 0.05)));
  // Vision saw the robot stay put, or creep: the wheels spun.
  EXPECT_TRUE(looksLikeSlip(d, SE2(0.0, 0.0, 0.0)));
  EXPECT_TRUE(looksLikeSlip(d, SE2(0.03, 0.01, 0.01)));
  // Vision went farther than the wheels claimed, or turned more their way: no slip makes that.
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.13, 0.0, 0.05)));
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.10, 0.0, 0.09)));
  // Vision thrown far off (walkers pull it anywhere): no slip either.
  EXPECT_FALSE(looksLikeSlip(d, SE2(-0.2, 0.1, 0.0)));
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.05, 0.0, 0.3)));
  // Sideways: a skid's worth over a frame at 30 Hz (tolerance + 3 cm + 0.3 m/s x 1/30 s = 4.92 cm),
  // on either side, and no more; over a second a skid carries farther (still within 25 cm).
  d.t0 = 0.0;
  d.t1 = 1.0 / 30.0;
  EXPECT_TRUE(looksLikeSlip(d, SE2(0.0, 0.047, 0.0)));
  EXPECT_TRUE(looksLikeSlip(d, SE2(0.0, -0.047, 0.0)));
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.0, 0.052, 0.0)));
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.0, -0.052, 0.0)));
  EXPECT_FALSE(looksLikeSlip(d, SE2(0.1, -0.2, 0.0)));
  d.t1 = 1.0;
  EXPECT_TRUE(looksLikeSlip(d, SE2(0.1, -0.2, 0.0)));
  // Vision alone missing the claim by more than the claim, the tolerance and a skid: more than a
  // slip starting now explains. 1 cm claimed over 1/30 s: 1 + 0.92 + 1 cm = 2.92 cm of miss at most.
  WheelDelta frame = d;
  frame.dp << 0.01, 0.0;
  frame.t1 = 1.0 / 30.0;
  EXPECT_FALSE(missBeyondTheClaim(frame, SE2(0.0, 0.0, 0.0)));     // stood: misses the claim
  EXPECT_FALSE(missBeyondTheClaim(frame, SE2(-0.019, 0.0, 0.0)));  // 2.9 cm
  EXPECT_TRUE(missBeyondTheClaim(frame, SE2(-0.0195, 0.0, 0.0)));  // 2.95 cm
  EXPECT_TRUE(missBeyondTheClaim(frame, SE2(0.01, 0.03, 0.0)));    // 3 cm sideways
  frame.t1 = 1.0;                                                  // over a second a skid goes 30 cm
  EXPECT_FALSE(missBeyondTheClaim(frame, SE2(0.01, 0.03, 0.0)));
  // A turn on the spot claimed, none seen.
  WheelDelta spin = d;
  spin.dp.setZero();
  spin.dphi = 0.1;
  EXPECT_TRUE(looksLikeSlip(spin, SE2(0.0, 0.0, 0.0)));
  EXPECT_FALSE(looksLikeSlip(spin, SE2(0.0, 0.0, -0.15)));
}

// The slip decision on hand-made evidence: wheels claiming 10 cm and 0.05 rad, vision alone seeing
// the robot stand still.
TEST(WheelsAgainstVision, SlipStartsOnClearEvidenceAndGoesOnWhileTheWheelsStillLie) {
  WheelDelta d;
  d.dp << 0.10, 0.0;
  d.dphi = 0.05;
  d.covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  SlipEvidence e;
  e.wheels = &d;
  e.T_b0_b1_fused = SE2(0.06, 0.0, 0.03);  // pulled between the two
  e.T_b0_b1_vision = SE2(0.0, 0.0, 0.0);
  e.fused_inliers = 100;
  e.vision_inliers = 150;  // > 1.3 x 100 + 10
  e.candidates = 160;
  e.min_to_start = 60;
  e.min_to_go_on = 30;
  EXPECT_TRUE(decideSlip(e));
  // Each condition of a start, broken alone:
  SlipEvidence b = e;
  b.vision_inliers = 140;  // not clearly more ...
  EXPECT_FALSE(decideSlip(b));
  b.strained = true;  // ... but noticeably more with the wheel edge beyond its gate
  EXPECT_TRUE(decideSlip(b));
  b = e;
  b.candidates = 177;  // vision alone leaves more than 15 % of the candidates unexplained
  EXPECT_FALSE(decideSlip(b));
  b = e;
  b.min_to_start = 151;  // too few for vision to place the frame
  EXPECT_FALSE(decideSlip(b));
  b = e;
  b.T_b0_b1_vision = SE2(0.2, 0.0, 0.05);  // vision went farther than the wheels: no slip does that
  EXPECT_FALSE(decideSlip(b));
  // Strained, vision explains only a few more, but both motions lie beyond the wheels' tolerance.
  b = e;
  b.strained = true;
  b.vision_inliers = 101;
  b.candidates = 110;
  EXPECT_TRUE(decideSlip(b));
  b.T_b0_b1_fused = SE2(0.099, 0.0, 0.05);  // the fused pose sided with the wheels
  EXPECT_FALSE(decideSlip(b));
  // Going on: about as many as fused, the wheels still claiming what vision does not see.
  b = e;
  b.was_slipping = true;
  b.vision_inliers = 99;
  EXPECT_TRUE(decideSlip(b));
  b.vision_inliers = 97;  // below 98 % of the fused pose's
  EXPECT_FALSE(decideSlip(b));
  b.vision_inliers = 99;
  b.min_to_go_on = 100;
  EXPECT_FALSE(decideSlip(b));
  b.min_to_go_on = 30;
  b.T_b0_b1_vision = SE2(0.097, 0.0, 0.049);  // the wheels agree with vision again: the slip ends
  EXPECT_FALSE(decideSlip(b));
  // From a pose vision alone placed, vision alone misses the claim by at most the claim, the
  // tolerance (9.2 mm) and 0.3 m/s over the delta (1 cm at 30 Hz): 11.9 cm here. Going 3 cm back
  // (a 13 cm miss) is no slip then, but is one when frames before took the wheels' side.
  b = e;
  b.was_slipping = true;
  b.vision_inliers = 99;
  d.t0 = 0.0;
  d.t1 = 1.0 / 30.0;
  b.from_vision_alone = true;
  b.T_b0_b1_vision = SE2(-0.015, 0.0, 0.0);
  EXPECT_TRUE(decideSlip(b));
  b.T_b0_b1_vision = SE2(-0.03, 0.0, 0.0);
  EXPECT_FALSE(decideSlip(b));
  b.from_vision_alone = false;
  EXPECT_TRUE(decideSlip(b));
  d.t1 = 0.0;
  // Worth checking at all: a slip going on, a strained edge, or many matches unexplained.
  EXPECT_FALSE(slipWorthChecking(false, false, 140, 100));
  EXPECT_TRUE(slipWorthChecking(false, false, 141, 100));
  EXPECT_TRUE(slipWorthChecking(true, false, 100, 100));
  EXPECT_TRUE(slipWorthChecking(false, true, 100, 100));
  // Creeping wheels (wheelsCreep over a stretch): a slip starts, or goes on, when vision alone
  // explains about as much as the fused pose, however small this frame's own miss.
  b = e;
  b.vision_inliers = 100;
  b.candidates = 110;
  b.T_b0_b1_vision = SE2(0.097, 0.0, 0.049);  // this frame alone within the wheels' tolerance
  EXPECT_FALSE(decideSlip(b));
  b.creeping = true;
  EXPECT_TRUE(decideSlip(b));
  b.vision_inliers = 97;  // vision alone lost some: the creep may be the walkers' pull
  EXPECT_FALSE(decideSlip(b));
  b.vision_inliers = 100;
  b.was_slipping = true;
  b.min_to_start = 101;  // too few to start, enough to go on
  EXPECT_TRUE(decideSlip(b));
  b.creeping = false;
  EXPECT_FALSE(decideSlip(b));
  // Stalled wheels (mono's wheelsStall): as creeping ones, but only while vision alone explains
  // 95 % of the candidates or more.
  b = e;
  b.vision_inliers = 100;
  b.candidates = 105;  // 95.2 %
  b.T_b0_b1_vision = SE2(0.097, 0.0, 0.049);
  b.stalled = true;
  EXPECT_TRUE(decideSlip(b));
  b.candidates = 106;  // 94.3 %: vision alone may be the one that is wrong
  EXPECT_FALSE(decideSlip(b));
  b.was_slipping = true;  // nor does it keep a slip going then
  EXPECT_FALSE(decideSlip(b));
  b.candidates = 105;
  EXPECT_TRUE(decideSlip(b));
  b.vision_inliers = 97;  // fewer than 98 % of the fused pose's
  b.candidates = 100;
  EXPECT_FALSE(decideSlip(b));
  e.wheels = nullptr;
  EXPECT_THROW(decideSlip(e), std::invalid_argument);
}

// Over a stretch: the wheels claim 6 cm ahead and 0.04 rad (sigma 1 mm / 1 mrad); vision alone's
// poses at its ends, each with 2 mm / 2 mrad sigma; beyond both, 5 mm / 5 mrad and 3 % / 5 % of
// the claim (the map's errors, the wheels' calibration).
TEST(WheelsAgainstVision, CreepIsTheWheelsClaimBeyondBothNoisesOverAStretch) {
  WheelDelta d;
  d.dp << 0.06, 0.0;
  d.dphi = 0.04;
  d.covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  const Eigen::Matrix3d sharp = Eigen::Vector3d(1 / 4e-6, 1 / 4e-6, 1 / 4e-6).asDiagonal();
  for (const double theta : {0.4, M_PI - 0.005, -M_PI + 0.002}) {  // across +-pi too
    const Eigen::Vector3d x0(1.0, -2.0, theta);
    auto at = [&](const SE2& T) { return (SE2::fromVector(x0) * T).vector(); };
    // Vision saw the robot stand: a creep.
    EXPECT_TRUE(wheelsCreep(d, x0, sharp, x0, sharp)) << theta;
    // Vision saw what the wheels claimed, within the noise: none.
    EXPECT_FALSE(wheelsCreep(d, x0, sharp, at(SE2(0.055, 0.004, 0.036)), sharp)) << theta;
    // A quarter of it along its arc: 4.5 cm short, beyond the gate (sigma about 6 mm).
    EXPECT_TRUE(wheelsCreep(d, x0, sharp, at(SE2(0.015, 0.0, 0.01)), sharp)) << theta;
    // 1.5 cm off: within what the map's errors and the calibration allow.
    EXPECT_FALSE(wheelsCreep(d, x0, sharp, at(SE2(0.045, 0.0, 0.04)), sharp)) << theta;
    // Vision went farther than the wheels: no slip does that (walkers pull vision anywhere).
    EXPECT_FALSE(wheelsCreep(d, x0, sharp, at(SE2(0.14, 0.0, 0.04)), sharp)) << theta;
    // A third of the claim, but 3 cm sideways, or turning against it: walkers, not the wheels.
    EXPECT_FALSE(wheelsCreep(d, x0, sharp, at(SE2(0.02, 0.03, 0.013)), sharp)) << theta;
    EXPECT_FALSE(wheelsCreep(d, x0, sharp, at(SE2(0.02, 0.0, -0.03)), sharp)) << theta;
    // Half of the claim along its arc (the robot slowed): a creep.
    EXPECT_TRUE(wheelsCreep(d, x0, sharp, at(SE2(0.03, 0.0, 0.02)), sharp)) << theta;
    // A vision that cannot tell (3 cm, 30 mrad sigma at one end): none.
    const Eigen::Matrix3d blurred = Eigen::Vector3d(1 / 9e-4, 1 / 9e-4, 1 / 9e-4).asDiagonal();
    EXPECT_FALSE(wheelsCreep(d, x0, blurred, x0, sharp)) << theta;
    // A pose vision did not pin down at all (no information): none, rather than NaN.
    EXPECT_FALSE(wheelsCreep(d, x0, Eigen::Matrix3d::Zero(), x0, sharp)) << theta;
  }
}

// A spin: vision alone saw at most half the wheels' travel and half their turn (each + 2 mm or
// 2 mrad), both at once, either way round; a skid that carried the robot on is not one.
TEST(WheelsAgainstVision, SpinIsTheRobotStandingWhileTheWheelsGoOn) {
  WheelDelta d;
  for (const double sign : {1.0, -1.0}) {
    d.dp << sign * 0.01, 0.0;  // a frame at 0.3 m/s
    d.dphi = sign * 0.004;
    EXPECT_TRUE(slipIsSpin(d, SE2(0.0, 0.0, 0.0))) << sign;      // stood
    EXPECT_TRUE(slipIsSpin(d, SE2(-0.0069, 0.0, 0.0))) << sign;  // 0.005 + 0.002 in any direction
    EXPECT_FALSE(slipIsSpin(d, SE2(0.0, 0.0072, 0.0))) << sign;
    EXPECT_TRUE(slipIsSpin(d, SE2(0.0, 0.0, -0.0039))) << sign;  // 0.002 + 0.002 rad either way
    EXPECT_FALSE(slipIsSpin(d, SE2(0.0, 0.0, 0.0041))) << sign;
    EXPECT_FALSE(slipIsSpin(d, SE2(sign * 0.008, 0.0, 0.0))) << sign;  // skidded on: 0.8 of the claim
  }
  // The slack alone for a claim of nothing (wheels at rest: no spin to speak of beyond it).
  d.dp.setZero();
  d.dphi = 0.0;
  EXPECT_TRUE(slipIsSpin(d, SE2(0.0019, 0.0, 0.0019)));
  EXPECT_FALSE(slipIsSpin(d, SE2(0.0021, 0.0, 0.0)));
  // A turn on the spot that spun: the turn is what counts.
  d.dphi = 0.1;
  EXPECT_TRUE(slipIsSpin(d, SE2(0.0, 0.0, 0.05)));
  EXPECT_FALSE(slipIsSpin(d, SE2(0.0, 0.0, 0.06)));
}

// After a blind stretch, a relocalisation is believed only on the way the wheels claimed (part
// of it, as a slip leaves the robot), within their tolerance and 3 cm / 0.03 rad: a quarter turn
// of radius 1 m claimed, noise-free but for the 5 mm / 5 mrad floor (so 3.5 cm, 0.035 rad).
TEST(WheelsAgainstVision, RelocalisedOnlyOnTheWayTheWheelsClaimed) {
  const double r = 1.0, turn = M_PI / 2;
  WheelDelta d;
  d.dp << r * std::sin(turn), r * (1 - std::cos(turn));
  d.dphi = turn;
  for (const double s : {0.0, 0.2, 0.5, 0.77, 1.0}) {  // where a slip may have left it, heading and all
    const double a = s * turn;
    EXPECT_TRUE(onTheClaimedWay(d, SE2(r * std::sin(a), r * (1 - std::cos(a)), a))) << s;
    // Off the arc (radially, at radius r + e) by more than 3.5 cm: no; by 3 cm, turned 0.03 rad: yes.
    const auto beside = [&](double e, double heading) {
      return SE2((r + e) * std::sin(a), r - (r + e) * std::cos(a), heading);
    };
    EXPECT_FALSE(onTheClaimedWay(d, beside(0.04, a))) << s;
    EXPECT_FALSE(onTheClaimedWay(d, beside(-0.04, a))) << s;
    EXPECT_TRUE(onTheClaimedWay(d, beside(0.03, a - 0.03))) << s;
    EXPECT_TRUE(onTheClaimedWay(d, beside(-0.03, a + 0.03))) << s;
    // Turned off the claim's heading there by more than the slack and what 3.5 cm along the arc
    // turns (0.035 rad at 1 m): no.
    EXPECT_FALSE(onTheClaimedWay(d, beside(0.0, a + 0.08))) << s;
    EXPECT_FALSE(onTheClaimedWay(d, beside(0.0, a - 0.08))) << s;
  }
  // The chord's midpoint is 29 cm inside the arc (its sagitta): a straight-line bound would take it.
  EXPECT_FALSE(onTheClaimedWay(d, SE2(0.5 * d.dp.x(), 0.5 * d.dp.y(), turn / 2)));
  // Farther than claimed, or the other way round: no slip leaves it there.
  EXPECT_FALSE(onTheClaimedWay(d, SE2(r * std::sin(1.2 * turn), r * (1 - std::cos(1.2 * turn)), 1.2 * turn)));
  EXPECT_FALSE(onTheClaimedWay(d, SE2(r * std::sin(-0.2 * turn), r * (1 - std::cos(-0.2 * turn)), -0.2 * turn)));
  // The wheels' own noise widens it: 2 cm of sigma on each axis adds 3 x 2.8 cm.
  d.covariance = Eigen::Vector3d(4e-4, 4e-4, 1e-6).asDiagonal();
  EXPECT_TRUE(onTheClaimedWay(d, SE2(r * std::sin(turn), r * (1 - std::cos(turn)) + 0.11, turn)));
  EXPECT_FALSE(onTheClaimedWay(d, SE2(r * std::sin(turn), r * (1 - std::cos(turn)) + 0.13, turn)));
  // A spin on the spot (the turn claimed, nothing seen): s = 0.
  WheelDelta spin;
  spin.dphi = 1.0;
  EXPECT_TRUE(onTheClaimedWay(spin, SE2(0.0, 0.0, 0.0)));
  EXPECT_TRUE(onTheClaimedWay(spin, SE2(0.0, 0.0, 0.6)));
  EXPECT_FALSE(onTheClaimedWay(spin, SE2(0.0, 0.0, -0.1)));
  EXPECT_FALSE(onTheClaimedWay(spin, SE2(0.05, 0.0, 0.3)));
}

// Mono's stall test: the claim's dominant part (travel against 3 cm, turn against 0.05 rad), less
// than half of it seen by vision alone, and not more than 0.3 of it backwards.
TEST(WheelsAgainstVision, StallIsLessThanHalfTheClaimSeenOverAStretch) {
  WheelDelta d;
  d.dp << 0.06, 0.0;  // 0.2 s at 0.3 m/s
  d.dphi = 0.02;
  EXPECT_DOUBLE_EQ(stallSeen(d, SE2(0.03, 0.01, 0.0)), 0.5);  // along the claim; sideways is not seen
  EXPECT_TRUE(wheelsStall(d, SE2(0.0, 0.0, 0.0)));            // stood
  EXPECT_TRUE(wheelsStall(d, SE2(0.029, 0.0, 0.02)));         // crawled: 0.48 of it
  EXPECT_FALSE(wheelsStall(d, SE2(0.03, 0.0, 0.02)));         // half of it: slowed, not stalled
  EXPECT_FALSE(wheelsStall(d, SE2(0.06, 0.0, 0.0)));          // all of it (a turn not seen is minor)
  EXPECT_FALSE(wheelsStall(d, SE2(0.09, 0.0, 0.02)));         // more than claimed
  EXPECT_TRUE(wheelsStall(d, SE2(-0.0175, 0.0, 0.0)));        // 0.29 of it back: a stall's noise
  EXPECT_FALSE(wheelsStall(d, SE2(-0.019, 0.0, 0.0)));        // more: a bump or a walker's pull
  // A claim too small to judge against mono's noise, in travel and in turn.
  d.dp << 0.029, 0.0;
  d.dphi = 0.049;
  EXPECT_FALSE(wheelsStall(d, SE2(0.0, 0.0, 0.0)));
  // A turn on the spot, either way round: the turn is judged.
  for (const double turn : {0.1, -0.1}) {
    d.dp << 0.004, 0.0;
    d.dphi = turn;
    EXPECT_TRUE(wheelsStall(d, SE2(0.004, 0.0, 0.0))) << turn;
    EXPECT_TRUE(wheelsStall(d, SE2(0.0, 0.0, 0.4 * turn))) << turn;
    EXPECT_FALSE(wheelsStall(d, SE2(0.0, 0.0, 0.6 * turn))) << turn;
    EXPECT_FALSE(wheelsStall(d, SE2(0.0, 0.0, -0.4 * turn))) << turn;  // turned the other way
  }
  // An arc whose turn outweighs its travel (0.2 rad / 0.05 = 4 against 4 cm / 3 cm): the turn
  // decides, though vision saw all of the travel.
  d.dp << 0.04, 0.0;
  d.dphi = 0.2;
  EXPECT_TRUE(wheelsStall(d, SE2(0.04, 0.0, 0.0)));
  EXPECT_FALSE(wheelsStall(d, SE2(0.0, 0.0, 0.2)));
  // No claim at all: all of it seen, never a stall.
  EXPECT_DOUBLE_EQ(stallSeen(WheelDelta(), SE2(0.1, 0.0, 0.1)), 1.0);
  EXPECT_FALSE(wheelsStall(WheelDelta(), SE2()));
}

}  // namespace
}  // namespace rvwo
