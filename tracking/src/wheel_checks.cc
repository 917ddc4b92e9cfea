// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/wheel_checks.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rvwo {

WheelTolerance::WheelTolerance(const WheelDelta& wheels)
    : translation(3.0 * std::sqrt(wheels.covariance(0, 0) + wheels.covariance(1, 1)) + 0.005),
      rotation(3.0 * std::sqrt(wheels.covariance(2, 2)) + 0.005) {}

namespace {
// How far a wheeled robot may move over the delta in a way its wheels do not report (a skid, at
// most 0.3 m/s), m.
double skidReach(const WheelDelta& wheels) {
  constexpr double kSkidSpeed = 0.3;  // m/s
  return kSkidSpeed * std::max(0.0, wheels.t1 - wheels.t0);
}
}  // namespace

bool looksLikeSlip(const WheelDelta& wheels, const SE2& T_b0_b1_vision) {
  constexpr double kMaxMiss = 0.25, kMaxTurnMiss = 0.2;  // m, rad
  const WheelTolerance tol(wheels);
  const double sp = tol.translation, sphi = tol.rotation;
  const Eigen::Vector2d miss = wheels.dp - T_b0_b1_vision.translation();
  const double turn_miss = wheels.dphi - T_b0_b1_vision.angle();
  if (miss.norm() > kMaxMiss || std::fabs(turn_miss) > kMaxTurnMiss) return false;
  if (std::fabs(turn_miss) > sphi && turn_miss * wheels.dphi <= 0) return false;  // turned more than they
  const double travel = wheels.dp.norm();
  if (travel < 1e-4) return true;  // a turn on the spot: no direction to hold vision to
  const Eigen::Vector2d along = wheels.dp / travel, v = T_b0_b1_vision.translation();
  if (v.dot(along) > travel + sp) return false;  // went farther
  // Sideways no more than a skid carries: kMaxSideways (what the frames before took while vision
  // could not tell yet) and skidReach. Walkers that no label marks pull vision alone
  // sideways by a walker's step: with no semantics, one took 5 cm a frame for 14 frames (dynamic,
  // 5.07 s: the first 12 cm sideways and 7 cm back at 0.3 m/s claimed), and the map 0.73 m off.
  constexpr double kMaxSideways = 0.03;  // m
  const double sideways = std::fabs(along.x() * v.y() - along.y() * v.x());
  return sideways <= sp + kMaxSideways + skidReach(wheels);
}

bool missBeyondTheClaim(const WheelDelta& wheels, const SE2& T_b0_b1_vision) {
  const double miss = (wheels.dp - T_b0_b1_vision.translation()).norm();
  return miss > wheels.dp.norm() + WheelTolerance(wheels).translation + skidReach(wheels);
}

bool onTheClaimedWay(const WheelDelta& wheels, const SE2& T_b0_b1_vision) {
  constexpr int kSteps = 200;  // along the way: 0.5 % of it (a metre's claim: 5 mm)
  const WheelTolerance tol(wheels);
  const Eigen::Vector3d xi = wheels.pose().log();
  for (int i = 0; i <= kSteps; ++i) {
    const SE2 at = SE2::exp((static_cast<double>(i) / kSteps) * xi);
    if ((at.translation() - T_b0_b1_vision.translation()).norm() <= tol.translation + kClaimedWaySlack &&
        std::fabs(wrapAngle(at.angle() - T_b0_b1_vision.angle())) <= tol.rotation + kClaimedWaySlack)
      return true;
  }
  return false;
}

bool slipIsSpin(const WheelDelta& wheels, const SE2& T_b0_b1_vision) {
  return T_b0_b1_vision.translation().norm() <= kSpinSeen * wheels.dp.norm() + kSpinSlack &&
         std::fabs(T_b0_b1_vision.angle()) <= kSpinSeen * std::fabs(wheels.dphi) + kSpinSlack;
}

bool wheelsDisagree(const WheelDelta& wheels, const SE2& T_b0_b1_vision) {
  const WheelTolerance tol(wheels);
  return (wheels.dp - T_b0_b1_vision.translation()).norm() > tol.translation ||
         std::fabs(wheels.dphi - T_b0_b1_vision.angle()) > tol.rotation;
}

bool wheelsCreep(const WheelDelta& wheels, const Eigen::Vector3d& x0, const Eigen::Matrix3d& information0,
                 const Eigen::Vector3d& x1, const Eigen::Matrix3d& information1) {
  // What neither covariance holds (sigmas): the map's errors, which vision alone's poses carry
  // (the landmarks change over a stretch, and local BA moves them), and the wheels' calibration
  // (radius, track). ORB-SLAM3 on the stereo slip scenario, vision alone against the wheels over
  // half a second of normal driving: up to 1.3 cm sideways and 11 mrad. On one run's trace, with
  // these values the difference passed the 3-DoF gate (16.27) in none of its 2700 frames outside
  // the slips, and within 2 to 6 frames of each slip's start.
  constexpr double kFloor = 0.005;                      // m, rad
  constexpr double kPerTravel = 0.03, kPerTurn = 0.05;  // of the wheels' claim
  // chi2 quantiles at 99.9 %: 1 DoF (the shortfall), 2 DoF (vision's motion off the claim's line).
  constexpr double kChi2Shortfall = 10.83, kChi2OffLine = 13.82;
  Eigen::Matrix3d J0, J1;
  const Eigen::Vector3d r = wheelResidual(x0, x1, wheels.dp, wheels.dphi, &J0, &J1);
  const Eigen::Matrix3d C0 = information0.inverse(), C1 = information1.inverse();
  const double sp = std::hypot(kFloor, kPerTravel * wheels.dp.norm());
  const double sphi = std::hypot(kFloor, kPerTurn * std::fabs(wheels.dphi));
  const Eigen::Matrix3d C = wheels.covariance + J0 * C0 * J0.transpose() + J1 * C1 * J1.transpose() +
                            Eigen::Vector3d(sp * sp, sp * sp, sphi * sphi).asDiagonal().toDenseMatrix();
  if (!C.allFinite()) return false;  // a pose vision did not pin down
  const Eigen::LDLT<Eigen::Matrix3d> W(C);
  // The wheels' claim c and vision's motion v = c + r, both from x0. A creep is the robot going
  // a shortened way along the claimed arc (slowed or stopped while the wheels went on): v = s c
  // with s clearly below 1. Walkers pull vision alone off that line (sideways, or turning against
  // the travel); such a difference is theirs, not the wheels'.
  const Eigen::Vector3d c(wheels.dp.x(), wheels.dp.y(), wheels.dphi), v = c + r;
  const double cc = c.dot(W.solve(c));
  if (!(cc > kChi2Shortfall)) return false;  // a claim within the noise of standing still
  const double s = c.dot(W.solve(v)) / cc;
  const Eigen::Vector3d off = v - s * c;
  return s < 1 && s > -0.5 && (1 - s) * (1 - s) * cc > kChi2Shortfall && off.dot(W.solve(off)) <= kChi2OffLine;
}

double stallSeen(const WheelDelta& claim, const SE2& T_b0_b1_vision) {
  const double travel = claim.dp.norm();
  if (travel / kStallTravel >= std::fabs(claim.dphi) / kStallTurn) {
    return travel > 0 ? T_b0_b1_vision.translation().dot(claim.dp) / (travel * travel) : 1.0;
  }
  return T_b0_b1_vision.angle() / claim.dphi;
}

bool wheelsStall(const WheelDelta& stretch, const SE2& T_b0_b1_vision) {
  if (stretch.dp.norm() < kStallTravel && std::fabs(stretch.dphi) < kStallTurn) return false;
  const double seen = stallSeen(stretch, T_b0_b1_vision);
  return seen >= -kStallBack && seen < kStallRatio;
}

bool wheelEdgeStrained(const WheelEdge& edge, const Eigen::Vector3d& x_prev, const Eigen::Vector3d& x) {
  return (edge.sqrtInformation() * edge.residual(x_prev, x)).squaredNorm() > kChi2WheelOutlier;
}

bool slipWorthChecking(bool was_slipping, bool strained, std::size_t matches, int fused_inliers) {
  return was_slipping || strained || static_cast<double>(matches) > 1.3 * fused_inliers + 10;
}

bool decideSlip(const SlipEvidence& e) {
  if (!e.wheels) throw std::invalid_argument("decideSlip: no wheel delta");
  const WheelDelta& d = *e.wheels;
  const int f = e.fused_inliers, v = e.vision_inliers;
  const bool disagree = wheelsDisagree(d, e.T_b0_b1_vision);
  const bool better = v > 1.3 * f + 10 ||
                      (e.strained && (v >= 1.05 * f + 10 || (disagree && v > f && wheelsDisagree(d, e.T_b0_b1_fused))));
  const bool slip_like = looksLikeSlip(d, e.T_b0_b1_vision);
  // From a pose vision alone placed (the frame before slipped), no frame before took the wheels'
  // side: vision alone misses their claim by at most the claim (the robot stood) and a skid.
  // Without semantics, walkers took vision alone 4-5 cm back a frame for six frames while the
  // wheels claimed 4 mm forward (dynamic, 2.0 s).
  if (e.from_vision_alone && missBeyondTheClaim(d, e.T_b0_b1_vision)) return false;
  const bool as_good = v >= 0.98 * f;
  const bool stall = e.stalled && v >= kStallExplained * e.candidates;
  const bool starts =
      (better || ((e.creeping || stall) && as_good)) && v >= e.min_to_start && v >= 0.85 * e.candidates && slip_like;
  const bool goes_on =
      e.was_slipping && v >= e.min_to_go_on && as_good && slip_like && (disagree || e.strained || e.creeping || stall);
  return starts || goes_on;
}

}  // namespace rvwo
