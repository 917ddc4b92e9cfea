// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "tracker.h"

#include <algorithm>
#include <cmath>

#include "rvwo/tracking/planar_pose.h"
#include "rvwo/tracking/wheel_checks.h"

namespace rvwo::estimator {

Tracker::Tracker(Context& ctx, Map& map, Wheels& wheels, Mapper& mapper, const FrontEnd& front_end)
    : ctx_(ctx),
      map_(map),
      wheels_(wheels),
      mapper_(mapper),
      front_end_(front_end),
      arbiter_(arbiterOptions(ctx.rig, ctx.opt, mapper.labelled())) {}

void Tracker::processFrame(const FrameInput& in, std::future<FrameFeatures> features) {
  FrameWork w;
  w.t = in.timestamp;
  // Labels that have come (threaded): applied now rather than at the next local BA, a keyframe
  // or more later, so that a walker's fresh landmarks stop counting as vision sooner.
  if (mapper_.asyncSegmenter()) mapper_.applyLabels(false);
  mapper_.waitForLag(w.t);
  predictFrame(&w);
  FrameRecord record{w.t, 0, SE2(), false};
  if (ctx_.opt.mode == Mode::kWheel) {
    {
      std::lock_guard<std::mutex> lock(map_.mutex);
      if (map_.final_pose.empty()) map_.final_pose[0] = SE2();  // the world's origin
    }
    record.ref_kf = 0;
    record.T_kf_b = w.predicted;
    finishFrame(record, w.t);
    return;
  }
  FrameFeatures fe = features.valid() ? features.get() : front_end_(in);
  w.f = std::move(fe.f);
  w.raw_image = fe.raw_image;

  std::unique_lock<std::mutex> lock(map_.mutex);
  if (map_.keyframes.empty() && map_.final_pose.empty()) {
    // The first keyframe at the world's origin, points from stereo or depth (metric: no visual
    // initialisation to check against the wheels).
    const int made = makeKeyFrame(w.t, Eigen::Vector3d::Zero(), std::move(w.f), {}, w.raw_image);
    record.ref_kf = map_.next_kf - 1;
    record.visual = made > 0;
    lock.unlock();
    mapper_.queueKeyFrame(w.t);
    finishFrame(record, w.t);
    return;
  }
  trackLocalMap(&w);
  if (!w.visual && !last_visual_) relocaliseBlindFrame(&w);
  settleFrame(&w);
  const bool make_kf = keepFrame(&w, &record);
  lock.unlock();
  if (make_kf) mapper_.queueKeyFrame(w.t);
  last_visual_ = w.visual;
  finishFrame(record, w.t);
}

void Tracker::predictFrame(FrameWork* w) {
  if (!has_last_) return;
  {
    std::lock_guard<std::mutex> lock(map_.mutex);
    const FrameRecord& prev = map_.frames.back();
    last_pose_ = map_.pose(prev);
  }
  w->delta = wheels_.delta(last_t_, w->t);
  w->predicted =
      w->delta ? last_pose_ * w->delta->pose() : last_pose_ * (ctx_.opt.mode == Mode::kVo ? velocity_ : SE2());
}

void Tracker::trackLocalMap(FrameWork* w) {
  auto t2 = Clock::now();
  w->x = w->predicted.vector();
  w->matches = searchByProjection(w->f, w->x, last_visual_ ? 1.0 : 2.0);
  if (static_cast<int>(w->matches.size()) < 2 * ctx_.opt.tracking.min_inliers && !w->delta) {
    w->matches = searchByProjection(w->f, w->x, 3.0);  // no wheels: the motion model may be far off
  }
  ctx_.timings.add("match", msSince(t2));
  auto t3 = Clock::now();
  // Vision counts only landmarks no label has called dynamic (in the slip test and for a visual
  // frame): a walker close in front fills the view with its own landmarks.
  w->trusted = map_.trustedOf(w->matches);
  FrameDecision d = arbiter_.decide(frameEvidence(*w));
  w->x = d.x;
  w->inliers = d.result.inliers;
  w->inlier = std::move(d.result.inlier);
  w->errors = std::move(d.result.error);
  w->strained = d.strained;
  if (d.slip) recordSlip(w->t, d.spin);
  if (d.gated) ++map_.counters.wheel_gated;
  ctx_.timings.add("pose", msSince(t3));
  w->visual = d.visual();
}

FrameEvidence Tracker::frameEvidence(const FrameWork& w) {
  FrameEvidence e;
  e.t = w.t;
  e.mono = &ctx_.mono_edge;
  e.stereo = ctx_.stereo();
  if (!w.matches.empty()) e.observations = poseObservations(w.f, w.matches);
  e.trusted = w.trusted;
  if (ctx_.opt.mode == Mode::kVw) e.wheels = w.delta;
  e.x_prev = last_pose_.vector();
  e.t_prev = last_t_;
  e.x_guess = w.x;
  // Coming back from the wheels, vision must be convincingly back (the first frames after a
  // blackout carry few, poorly placed matches: one such frame put the pose 6 cm off).
  e.after_blind = !last_visual_;
  e.wheels_between = [this](double t0, double t1) { return wheels_.delta(t0, t1); };
  return e;
}

ArbiterOptions Tracker::arbiterOptions(const Rig& r, const EstimatorOptions& o, bool labelled) {
  ArbiterOptions a = ArbiterOptions::estimator(r.sensor == Sensor::kMono).apply(o.tracking);
  a.wheel_gate = a.wheel_gate && o.kernel == KernelChoice::kAdaptive;
  // One frame of stereo or depth may explain a robot standing while its wheels turn on as well as
  // the wheels' claim; half a second of vision alone's own track tells them apart, a track only
  // labels (with the adaptive kernel, which heeds them) keep off the walkers (docs/decisions/0011).
  if (a.drift == DriftTest::kNone && o.kernel == KernelChoice::kAdaptive && labelled) a.drift = DriftTest::kCreep;
  a.pose.huber = o.kernel == KernelChoice::kHuber;
  return a;
}

void Tracker::recordSlip(double t, bool spin) {
  ++slip_frames_;
  wheels_.markSlip(t, spin);
}

void Tracker::relocaliseBlindFrame(FrameWork* w) {
  auto t5 = Clock::now();
  std::optional<Eigen::Vector3d> x_map;
  if (ctx_.rig.sensor != Sensor::kMono) {
    x_map = relocalise(w->f);
  } else if (arbiter_.wheelsDoubted()) {
    x_map = alongTheWheelsWay(w->f, w->t);
  }
  if (x_map) {
    w->x = *x_map;
    w->matches = searchByProjection(w->f, w->x, 1.0);
    w->matches.erase(
        std::remove_if(w->matches.begin(), w->matches.end(), [&](const Match& m) { return !map_.isTrusted(m.point); }),
        w->matches.end());
    w->inliers = optimisePose(w->f, w->matches, std::nullopt, w->x, &w->x, &w->inlier, &w->errors);
    w->trusted = map_.trustedOf(w->matches);
    w->visual =
        arbiter_.believeRelocalisation(w->x, w->countTrusted(w->inlier), [&] { return onTheWheelsWay(w->x, w->t); });
    if (w->visual) ++map_.counters.relocalisations;
  }
  ctx_.timings.add("relocalise", msSince(t5));
}

void Tracker::settleFrame(FrameWork* w) {
  const FrameOutcome o = arbiter_.settle(w->visual);
  w->after_slip = o.held;
  w->wheels_doubted = o.wheels_doubted;
  // Held still while the wheels went on, as far as the map knows: a spin, whose wheel edge sits
  // out local BA's first round and comes back in the second only if vision's map_.keyframes agree
  // with it (docs/decisions/0003).
  if (o.held) wheels_.markSlip(w->t, true);
}

bool Tracker::keepFrame(FrameWork* w, FrameRecord* record) {
  const SE2 T_w_b = w->visual ? SE2::fromVector(w->x) : w->after_slip ? last_pose_ : w->predicted;
  std::vector<std::int64_t> point_of(w->f.size(), -1);
  if (w->visual) {
    for (std::size_t k = 0; k < w->matches.size(); ++k) {
      if (!w->inlier[k]) continue;
      MapPoint& p = map_.points.at(w->matches[k].point);
      ++p.found;
      point_of[w->matches[k].feature] = static_cast<std::int64_t>(p.id);
    }
  }
  // Eq. 6: every matched landmark's latest whitened error (outliers included: that is the point).
  if (w->visual && ctx_.opt.kernel == KernelChoice::kAdaptive) {
    for (std::size_t k = 0; k < w->matches.size(); ++k)
      map_.reliability.observe(w->matches[k].point, std::nullopt, w->errors[k]);
  }
  if (w->visual && !last_visual_ && has_last_) spreadCorrection(T_w_b * w->predicted.inverse(), w->t);
  // Features matched to an untrusted landmark (adaptive kernel): a walker's, or one whose labels
  // are still to come. They neither ask for a keyframe (a walker close in front is forever
  // "close and untracked") nor give it a second, fresh landmark of the same walker.
  std::vector<char> on_walker(w->f.size(), 0);
  if (ctx_.opt.kernel == KernelChoice::kAdaptive) {
    for (std::size_t k = 0; k < w->matches.size(); ++k) on_walker[w->matches[k].feature] |= !w->trusted[k];
  }
  ++frames_since_kf_;
  const std::uint64_t ref = std::prev(map_.keyframes.end())->first;
  const KeyFrame& ref_kf = map_.keyframes.at(ref);
  const bool make_kf = keyFrameDue(*w, T_w_b, point_of, on_walker, ref_kf);
  if (make_kf) {
    auto t4 = Clock::now();
    std::vector<std::pair<int, std::uint64_t>> label_only;
    for (std::size_t k = 0; w->visual && k < w->matches.size(); ++k) {
      if (!w->inlier[k]) label_only.emplace_back(w->matches[k].feature, w->matches[k].point);
    }
    makeKeyFrame(w->t, T_w_b.vector(), std::move(w->f), point_of, w->raw_image, w->inliers, on_walker);
    map_.keyframes.at(map_.next_kf - 1).label_only = std::move(label_only);
    record->ref_kf = map_.next_kf - 1;
    record->T_kf_b = SE2();
    ctx_.timings.add("keyframe", msSince(t4));
  } else {
    record->ref_kf = ref;
    record->T_kf_b = SE2::fromVector(ref_kf.x).inverse() * T_w_b;
  }
  record->visual = w->visual;
  record->slip = w->visual && arbiter_.slipping();
  return make_kf;
}

bool Tracker::keyFrameDue(const FrameWork& w, const SE2& T_w_b, const std::vector<std::int64_t>& point_of,
                          const std::vector<char>& on_walker, const KeyFrame& ref_kf) const {
  int close_tracked = 0, close_untracked = 0;
  const double close = ctx_.opt.max_depth_baselines * ctx_.rig.baseline;
  for (std::size_t i = 0; i < w.f.size(); ++i) {
    if (w.f.depth[i] <= 0 || w.f.depth[i] > close || (point_of[i] < 0 && on_walker[i])) continue;
    (point_of[i] >= 0 ? close_tracked : close_untracked)++;
  }
  if (w.visual) {
    return frames_since_kf_ >= ctx_.opt.keyframe_max_frames ||
           (frames_since_kf_ >= 2 && w.inliers < ctx_.opt.keyframe_ratio * ref_kf.tracked) ||
           (!arbiter_.slipping() && !w.strained && close_tracked < 100 && close_untracked > 70);
  }
  if (ctx_.rig.sensor == Sensor::kMono) {
    // Mono: once the wheels have moved the camera far enough for a baseline.
    return (ctx_.T_w_c(T_w_b.vector()).translation() - ctx_.T_w_c(ref_kf.x).translation()).norm() >=
               ctx_.opt.mono_min_baseline &&
           static_cast<int>(w.f.size()) >= 4 * ctx_.opt.tracking.min_inliers;
  }
  const int with_depth =
      static_cast<int>(std::count_if(w.f.depth.begin(), w.f.depth.end(), [](float d) { return d > 0; }));
  // Not while the landmarks in view say the wheels are wrong (FrameOutcome::wheels_doubted): a map
  // restarted there is the slip's. As the wheels run away from the map its landmarks leave the
  // projection search, so the doubt outlasts the frames that raised it by Tracking.SlipHold.
  return frames_since_kf_ >= 3 && with_depth >= 4 * ctx_.opt.tracking.min_inliers && !w.after_slip && !w.wheels_doubted;
}

int Tracker::makeKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                          const cv::Mat& image, int tracked, const std::vector<char>& no_new_point) {
  const int made = map_.createKeyFrame(t, x, std::move(f), std::move(point_of), image, tracked, no_new_point);
  frames_since_kf_ = 0;
  mapper_.askForLabels(std::prev(map_.keyframes.end())->second);
  return made;
}

const FrameRecord* Tracker::lastVisualFrame(bool slips_too) const {
  for (auto r = map_.frames.rbegin(); r != map_.frames.rend(); ++r) {
    if (r->visual && (slips_too || !r->slip)) return &*r;
  }
  return nullptr;
}

bool Tracker::onTheWheelsWay(const Eigen::Vector3d& x, double t) const {
  const FrameRecord* last = lastVisualFrame(false);
  if (!last) return true;
  const FrameRecord& v = *last;
  const std::optional<WheelDelta> stretch = wheels_.delta(v.t, t);
  if (!stretch || stretch->t0 > v.t + 1e-6) return true;  // no readings over the whole stretch to hold it to
  return onTheClaimedWay(*stretch, map_.pose(v).inverse() * SE2::fromVector(x));
}

void Tracker::spreadCorrection(const SE2& C, double t) {
  std::size_t first = map_.frames.size();
  while (first > 0 && !map_.frames[first - 1].visual) --first;
  if (first == map_.frames.size() || first == 0) return;
  const double t0 = map_.frames[first - 1].t;
  const Eigen::Vector3d xi = C.log();
  for (std::size_t j = first; j < map_.frames.size(); ++j) {
    FrameRecord& r = map_.frames[j];
    const double s = (r.t - t0) / (t - t0);
    const SE2 T_w_kf = map_.kfPose(r.ref_kf);
    r.T_kf_b = T_w_kf.inverse() * (SE2::exp(s * xi) * (T_w_kf * r.T_kf_b));
  }
}

void Tracker::finishFrame(const FrameRecord& record, double t) {
  PoseEstimate pe;
  {
    std::lock_guard<std::mutex> lock(map_.mutex);
    map_.frames.push_back(record);
    const SE2 pose = map_.pose(record);
    if (has_last_) velocity_ = last_pose_.inverse() * pose;
    last_pose_ = pose;
    pe = {t, pose, record.visual};
    if (!record.visual && ctx_.opt.mode != Mode::kWheel) {
      ++map_.counters.wheel_only_frames;
      auto& iv = map_.counters.wheel_only_intervals;
      const double dt = 1.5 / ctx_.rig.fps;
      if (!iv.empty() && t - iv.back().second <= dt) {
        iv.back().second = t;
      } else {
        iv.emplace_back(t, t);
      }
    }
  }
  last_t_ = t;
  has_last_ = true;
  if (callback_) callback_(pe);
}

std::optional<Eigen::Vector3d> Tracker::alongTheWheelsWay(const Features& f, double t) {
  const FrameRecord* v = lastVisualFrame(true);
  if (!v) return std::nullopt;
  const std::optional<WheelDelta> stretch = wheels_.delta(v->t, t);
  if (!stretch) return std::nullopt;
  const SE2 T_w_v = map_.pose(*v);
  std::optional<Eigen::Vector3d> best;
  int most = ctx_.opt.tracking.min_inliers - 1;
  for (double s : {0.0, 0.25, 0.5, 0.75}) {  // 1: the wheels' own prediction, searched already
    const Eigen::Vector3d x = (T_w_v * stretch->pose().fraction(s)).vector();
    const std::vector<Match> matches = searchByProjection(f, x, 2.0, false);
    const std::vector<char> trusted = map_.trustedOf(matches);
    const int n = static_cast<int>(std::count(trusted.begin(), trusted.end(), 1));
    if (n > most) {
      most = n;
      best = x;
    }
  }
  return best;
}

std::vector<Match> Tracker::searchByProjection(const Features& f, const Eigen::Vector3d& x, double radius_scale,
                                               bool count_visible) {
  std::vector<Match> matches;
  std::vector<int> best_dist(f.size(), 256);
  std::vector<std::int64_t> best_point(f.size(), -1);
  const Eigen::Isometry3d T_c_w = ctx_.T_w_c(x).inverse();
  for (auto& [id, p] : map_.points) {
    const Eigen::Vector3d P_c = T_c_w * p.P;
    const double d = P_c.norm();
    if (P_c.z() < 0.1 || d > 3 * p.distance || d < p.distance / 3) continue;
    Eigen::Vector3d h;  // (u, v, u_R); mono: (u, v, unused)
    if (!ctx_.predict(x, p.P, &h)) continue;
    if (h.x() < 0 || h.y() < 0 || h.x() >= ctx_.rig.width || h.y() >= ctx_.rig.height) continue;
    p.visible += count_visible;
    const int level = predictLevel(p, d);
    const float r = static_cast<float>(ctx_.opt.search_radius * radius_scale * std::pow(ctx_.opt.scale_factor, level));
    BestTwo match;
    for (int i : f.near(static_cast<float>(h.x()), static_cast<float>(h.y()), r, level - 1, level + 1)) {
      if (ctx_.rig.sensor != Sensor::kMono && f.u_right[i] >= 0 && std::fabs(f.u_right[i] - h.z()) > r) continue;
      match.offer(hammingDistance(p.descriptor, f.descriptors.row(i)), i);
    }
    if (match.index < 0 || match.best > 50 || match.best > 0.9 * match.second) continue;
    if (match.best < best_dist[match.index]) {
      best_dist[match.index] = match.best;
      best_point[match.index] = static_cast<std::int64_t>(id);
    }
  }
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (best_point[i] >= 0) matches.push_back({static_cast<std::uint64_t>(best_point[i]), static_cast<int>(i)});
  }
  return matches;
}

int Tracker::predictLevel(const MapPoint& p, double d) const {
  const int l = p.level + static_cast<int>(std::lround(std::log(p.distance / d) / std::log(ctx_.opt.scale_factor)));
  return std::clamp(l, 0, ctx_.opt.levels - 1);
}

std::optional<Eigen::Vector3d> Tracker::relocalise(const Features& f) const {
  if (ctx_.rig.sensor == Sensor::kMono) return std::nullopt;
  // A seed: the projection search and the pose optimisation after it decide.
  const std::size_t enough = static_cast<std::size_t>(ctx_.opt.tracking.min_inliers);
  std::vector<std::uint64_t> ids;
  cv::Mat map_descriptors;
  for (const auto& [id, p] : map_.points) {
    if (!map_.isTrusted(id) || ctx_.rejected(map_.kernelAlpha(id))) continue;
    ids.push_back(id);
    map_descriptors.push_back(p.descriptor);
  }
  std::vector<int> with_depth;
  cv::Mat frame_descriptors;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.depth[i] <= 0) continue;
    with_depth.push_back(static_cast<int>(i));
    frame_descriptors.push_back(f.descriptors.row(static_cast<int>(i)));
  }
  if (ids.size() < enough || with_depth.size() < enough) return std::nullopt;
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(frame_descriptors, map_descriptors, knn, 2);
  struct Pair {
    Eigen::Vector2d p_b, q_w;  // the feature in the robot's frame, its landmark in the world's
    double tolerance;          // m: stereo depth grows less sure with distance
  };
  std::vector<Pair> pairs;
  for (std::size_t k = 0; k < knn.size(); ++k) {
    if (knn[k].empty() || knn[k][0].distance > 50) continue;
    if (knn[k].size() > 1 && knn[k][0].distance > 0.8f * knn[k][1].distance) continue;
    const int i = with_depth[k];
    const cv::KeyPoint& kp = f.keypoints[i];
    const Eigen::Vector3d P_b =
        ctx_.rig.T_b_c * (f.depth[i] * ctx_.rig.camera->unproject(Eigen::Vector2d(kp.pt.x, kp.pt.y)));
    const Eigen::Vector3d& P_w = map_.points.at(ids[knn[k][0].trainIdx]).P;
    if (std::fabs(P_b.z() - P_w.z()) > 0.2) continue;
    pairs.push_back({P_b.head<2>(), P_w.head<2>(), 0.05 + 0.02 * f.depth[i]});
  }
  if (pairs.size() < enough) return std::nullopt;
  std::uint64_t state = 0x9E3779B97F4A7C15ull;  // a fixed seed: the same frame, the same answer
  auto draw = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::size_t>(state >> 33) % pairs.size();
  };
  std::size_t best = 0;
  SE2 T_best;
  for (int it = 0; it < 300; ++it) {
    const Pair &a = pairs[draw()], &b = pairs[draw()];
    const Eigen::Vector2d dp = b.p_b - a.p_b, dq = b.q_w - a.q_w;
    if (dp.norm() < 0.3 || std::fabs(dp.norm() - dq.norm()) > a.tolerance + b.tolerance) continue;
    const double theta = std::atan2(dq.y(), dq.x()) - std::atan2(dp.y(), dp.x());
    const SE2 T(a.q_w - rotation2(theta) * a.p_b, theta);
    std::size_t agree = 0;
    for (const Pair& p : pairs) agree += (T.act(p.p_b) - p.q_w).norm() < p.tolerance;
    if (agree > best) {
      best = agree;
      T_best = T;
    }
  }
  if (best < enough) return std::nullopt;
  return T_best.vector();
}

std::vector<PoseObservation> Tracker::poseObservations(const Features& f, const std::vector<Match>& matches) const {
  std::vector<PoseObservation> obs(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) {
    PoseObservation& o = obs[k];
    o.P_w = map_.points.at(matches[k].point).P;
    o.z = Context::observation(f, matches[k].feature);
    o.stereo = ctx_.hasStereo(f, matches[k].feature);
    o.sigma_px = ctx_.sigmaAt(f.keypoints[matches[k].feature].octave);
    o.alpha = map_.kernelAlpha(matches[k].point);
    // With the adaptive kernel a landmark any label has called dynamic does not place a frame,
    // though its alpha (0.51 after one person label, by the weights of ReliabilityParams) keeps
    // it in the map: a frame's pose is cheap to get wrong the other way (the wheels carry it),
    // while walkers' landmarks, freshly labelled and given depth, may outnumber the static ones
    // (dynamic 30 s cut, 8-10 s: a 0.4 deg yaw error; 0.135 -> 0.058 % of the path). Beyond
    // the paper, which weighs every landmark by its alpha alone. Huber and a fixed alpha know
    // nothing of labels.
    o.usable =
        !ctx_.rejected(o.alpha) && (ctx_.opt.kernel != KernelChoice::kAdaptive || map_.isTrusted(matches[k].point));
  }
  return obs;
}

int Tracker::optimisePose(const Features& f, const std::vector<Match>& matches, const std::optional<WheelEdge>& prior,
                          const Eigen::Vector3d& x_prev, Eigen::Vector3d* x, std::vector<char>* inlier,
                          std::vector<double>* errors) const {
  const WheelPrior wheel{prior ? &*prior : nullptr, x_prev};
  PlanarPoseResult r = optimisePlanarPose(ctx_.mono_edge, ctx_.stereo(), poseObservations(f, matches), wheel,
                                          arbiter_.options().pose, x);
  inlier->swap(r.inlier);
  errors->swap(r.error);
  return r.inliers;
}

}  // namespace rvwo::estimator
