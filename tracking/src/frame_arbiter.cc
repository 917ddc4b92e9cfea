// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/frame_arbiter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "rvwo/tracking/wheel_checks.h"

namespace rvwo {

int countTrusted(const std::vector<char>& inlier, const std::vector<char>& trusted) {
  int n = 0;
  for (std::size_t k = 0; k < inlier.size(); ++k) n += inlier[k] && trusted[k];
  return n;
}

ArbiterOptions ArbiterOptions::estimator(bool mono) {
  ArbiterOptions a;
  a.after_blind = 3;
  a.overrule = 1;
  a.judge_every_frame = false;
  a.bound_miss_after_slip = true;
  a.drift = mono ? DriftTest::kStall : DriftTest::kNone;
  a.wheel_gate = !mono;
  return a;
}

// Twice the bar (ORB-SLAM3's 30 inliers: WheelInputParams) for vision alone to overrule the
// wheels; the slip judged on every solve, with the creep test over vision alone's own track
// (solved every frame: 0.5 to 2 ms for 100 to 300 matches, rvwo_bench_tracking).
ArbiterOptions ArbiterOptions::orbslam3() {
  ArbiterOptions a;
  a.after_blind = 1;
  a.overrule = 2;
  a.judge_every_frame = true;
  a.bound_miss_after_slip = false;
  a.drift = DriftTest::kCreep;
  return a;
}

ArbiterOptions& ArbiterOptions::apply(const TrackingOptions& t) {
  min_inliers = t.min_inliers;
  slip_start = t.slip_min_inliers;
  check_slip = t.slip_check;
  wheel_gate = wheel_gate && t.wheel_gate;
  hold = t.slip_hold;
  hold_min_frames = t.slip_hold_min_frames;
  pose.barron_scale = t.barron_scale;
  pose.out_of_plane = t.outOfPlane();
  return *this;
}

FrameArbiter::FrameArbiter(const ArbiterOptions& options) : options_(options) {
  if (options.min_inliers < 1 || options.after_blind < 1 || options.overrule < 1 || !(options.slip_start >= 0))
    throw std::invalid_argument("ArbiterOptions: min_inliers, after_blind and overrule must be >= 1, slip_start >= 0");
}

FrameDecision FrameArbiter::decide(const FrameEvidence& e) {
  if (!e.mono || e.trusted.size() != e.observations.size())
    throw std::invalid_argument("FrameArbiter::decide: no mono edge, or not one trusted flag per observation");
  FrameDecision d;
  d.x = e.x_guess;
  d.slip_from = e.t_prev;
  d.candidates = static_cast<int>(std::count(e.trusted.begin(), e.trusted.end(), 1));
  d.to_place = (e.after_blind ? options_.after_blind : 1) * options_.min_inliers;
  const bool was_slipping = slipping_;
  slipping_ = false;  // until this frame says otherwise
  frame_ = Frame{e.t, e.t_prev, e.wheels, was_slipping, false};
  std::optional<WheelEdge> edge;
  if (e.wheels) {
    try {
      edge.emplace(*e.wheels);
    } catch (const std::invalid_argument&) {  // degenerate covariance (no motion, no floor): vision alone
    }
  }
  // The stall test's track is of consecutive frames with the wheels: a gap starts it again.
  if (options_.drift == DriftTest::kStall && (!edge || e.observations.empty())) {
    track_.clear();
    stall_run_ = 0;
  }
  if (e.observations.empty()) return d;
  d.result = optimisePlanarPose(*e.mono, e.stereo, e.observations, WheelPrior{edge ? &*edge : nullptr, e.x_prev},
                                options_.pose, &d.x);
  d.strained = edge && wheelEdgeStrained(*edge, e.x_prev, d.x);
  if (edge && options_.check_slip) judgeSlip(e, *e.wheels, was_slipping, &d);
  if (edge && d.strained && !d.slip && !e.after_blind && options_.wheel_gate) gate(e, *edge, &d);
  d.placed = countTrusted(d.result.inlier, e.trusted);
  d.contradicts_wheels = d.candidates >= options_.min_inliers / 2 && d.placed < 0.6 * d.candidates &&
                         d.vision_alone_placed >= 0.6 * d.candidates;
  frame_.contradicts_wheels = d.contradicts_wheels;
  if (d.slip) {
    // A hold goes on with the slip it held: vision back for a frame or two between blind stretches
    // is the same slip, and the blindness after it holds again (docs/decisions/0003).
    slip_run_ = (was_slipping || holding_) ? slip_run_ + 1 : 1;
    last_slip_t_ = e.t;
  }
  return d;
}

bool FrameArbiter::believeRelocalisation(const Eigen::Vector3d& x, int placed,
                                         const std::function<bool()>& on_the_wheels_way) {
  const int bar = options_.min_inliers;
  int run = 0;
  if (placed >= bar) {
    const bool agrees = relocalised_.placed > 0 && relocalised_.t == frame_.t_prev && frame_.wheels &&
                        onTheClaimedWay(*frame_.wheels, SE2::fromVector(relocalised_.x).inverse() * SE2::fromVector(x));
    run = (agrees ? relocalised_.placed : 0) + placed;
    relocalised_ = {frame_.t, x, run};
  }
  const bool enough = placed >= kRelocaliseAlone * bar || (run > placed && run >= kRelocaliseRun * bar);
  return enough && (placed >= kRelocaliseAnywhere * bar || !on_the_wheels_way || on_the_wheels_way());
}

FrameOutcome FrameArbiter::settle(bool visual) {
  FrameOutcome o;
  o.held = !visual && !slipping_ && frame_.t - last_slip_t_ <= options_.hold && slip_run_ >= options_.hold_min_frames &&
           (holding_ || frame_.was_slipping);
  holding_ = o.held;
  o.wheels_doubted = !visual && wheelsDoubted();
  if (visual) {
    doubted_t_ = -1e300;
  } else if (frame_.contradicts_wheels) {
    doubted_t_ = frame_.t;
  }
  return o;
}

FrameArbiter::VisionAlone FrameArbiter::solveVisionAlone(const FrameEvidence& e) const {
  VisionAlone v;
  v.x = e.x_prev;
  v.result = optimisePlanarPose(*e.mono, e.stereo, e.observations, WheelPrior{nullptr, e.x_prev}, options_.pose, &v.x);
  v.placed = countTrusted(v.result.inlier, e.trusted);
  return v;
}

// Creep: vision alone's pose joins the track where it would overrule the wheels (the go-on bar and
// 85 % of the candidates); a frame solved again replaces its entry. The creep must show over the
// whole stretch and over its recent part (from the last entry kCreepRecent back or more), so that
// it ends once the robot has driven on for kCreepRecent, not for the whole stretch.
bool FrameArbiter::creeps(const FrameEvidence& e, const VisionAlone& v, int bar, int candidates, double* slip_from) {
  const bool placed = v.placed >= bar && v.placed >= 0.85 * static_cast<double>(candidates);
  if (!track_.empty() && track_.back().t == e.t) track_.pop_back();
  while (!track_.empty() && track_.front().t < e.t - kCreepStretch) track_.pop_front();
  auto creepsFrom = [&](const Seen& from) {
    const std::optional<WheelDelta> stretch = e.wheels_between(from.t, e.t);
    return stretch && wheelsCreep(*stretch, from.x, from.information, v.x, v.result.information);
  };
  bool creeping = false;
  if (placed && !track_.empty() && e.wheels_between && creepsFrom(track_.front())) {
    auto recent =
        std::find_if(track_.rbegin(), track_.rend(), [&](const Seen& s) { return s.t <= e.t - kCreepRecent; });
    creeping = recent == track_.rend() || recent->t == track_.front().t || creepsFrom(*recent);
    if (creeping) *slip_from = std::min(*slip_from, track_.front().t);
  }
  if (placed) track_.push_back({e.t, v.x, v.result.information});
  return creeping;
}

// Stall: vision alone's pose joins the track where it places the frame (else the track starts
// again); stalled once kStallFrames stretches in a row show it, this frame too seeing less than
// half the claim (a stretch over a stall's end still reads as stalled for up to half its length
// once the robot has driven on: 4 frames after a 1 s mono slip, 2.4 cm). (The estimator's, mono.)
bool FrameArbiter::stalls(const FrameEvidence& e, const VisionAlone& v, int bar) {
  while (!track_.empty() && track_.front().t < e.t - kStallStretch - 1e-6) track_.pop_front();
  if (v.placed < bar) {
    track_.clear();
    stall_run_ = 0;
  } else {
    bool stall = false;
    if (!track_.empty() && e.t - track_.front().t >= 0.75 * kStallStretch && e.wheels_between) {
      if (const std::optional<WheelDelta> stretch = e.wheels_between(track_.front().t, e.t)) {
        stall = wheelsStall(*stretch, SE2::fromVector(track_.front().x).inverse() * SE2::fromVector(v.x));
      }
    }
    stall_run_ = stall ? stall_run_ + 1 : 0;
    track_.push_back({e.t, v.x, Eigen::Matrix3d::Zero()});
  }
  return stall_run_ >= kStallFrames &&
         stallSeen(*e.wheels, SE2::fromVector(e.x_prev).inverse() * SE2::fromVector(v.x)) < kStallRatio;
}

void FrameArbiter::judgeSlip(const FrameEvidence& e, const WheelDelta& wheels, bool was_slipping, FrameDecision* d) {
  const int go_on = options_.overrule * d->to_place;
  std::optional<VisionAlone> v;
  bool creeping = false, stalled = false;
  if (options_.drift != DriftTest::kNone) {
    v = solveVisionAlone(e);
    if (options_.drift == DriftTest::kCreep) creeping = creeps(e, *v, go_on, d->candidates, &d->slip_from);
    if (options_.drift == DriftTest::kStall) stalled = stalls(e, *v, d->to_place);
  }
  if (!options_.judge_every_frame &&
      !(slipWorthChecking(was_slipping, d->strained, e.observations.size(), d->result.inliers) || creeping || stalled))
    return;
  if (!v) v = solveVisionAlone(e);
  const SE2 T_w_prev = SE2::fromVector(e.x_prev);
  SlipEvidence s;
  s.wheels = &wheels;
  s.T_b0_b1_fused = T_w_prev.inverse() * SE2::fromVector(d->x);
  s.T_b0_b1_vision = T_w_prev.inverse() * SE2::fromVector(v->x);
  s.fused_inliers = countTrusted(d->result.inlier, e.trusted);
  s.vision_inliers = v->placed;
  s.candidates = d->candidates;
  s.strained = d->strained;
  s.creeping = creeping;
  s.stalled = stalled;
  s.was_slipping = was_slipping;
  s.from_vision_alone = options_.bound_miss_after_slip && was_slipping;
  // Only vision that would place the frame overrules the wheels.
  s.min_to_go_on = go_on;
  s.min_to_start = std::max(go_on, static_cast<int>(std::ceil(options_.slip_start * options_.min_inliers)));
  if (options_.drift == DriftTest::kStall && !was_slipping && missBeyondTheClaim(wheels, s.T_b0_b1_vision))
    s.min_to_start = std::max(s.min_to_start, kBeyondTheClaimStart * options_.min_inliers);
  d->vision_alone_placed = v->placed;
  if (!decideSlip(s)) return;
  slipping_ = true;
  d->slip = true;
  d->spin = slipIsSpin(wheels, s.T_b0_b1_vision);
  d->x = v->x;
  d->result = std::move(v->result);
}

// The wheel gate: not after a blind stretch, where vision coming back corrects the wheels' drift.
void FrameArbiter::gate(const FrameEvidence& e, const WheelEdge& edge, FrameDecision* d) const {
  const Eigen::Vector3d x_predicted = (SE2::fromVector(e.x_prev) * e.wheels->pose()).vector();
  PlanarPoseResult gated;
  if (solveFromTheWheels(*e.mono, e.stereo, e.observations, WheelPrior{&edge, e.x_prev}, options_.pose, x_predicted,
                         e.trusted, d->to_place, &d->x, &gated)) {
    d->result = std::move(gated);
    d->gated = true;
  }
}

}  // namespace rvwo
