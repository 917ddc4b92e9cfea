// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The tracker: a frame predicted, matched, solved, judged (wheels or vision), relocalised, kept.
#include "impl.h"

namespace rvwo::estimator {

bool Estimator::Impl::chi2(bool stereo, const Eigen::Vector3d& x, const Eigen::Vector3d& P, const Eigen::Vector3d& z,
                           double sigma, double* out) const {
  PoseObservation o;
  o.P_w = P;
  o.z = z;
  o.stereo = stereo;
  o.sigma_px = sigma;
  return whitenedChi2(mono_edge, stereo_edge ? &*stereo_edge : nullptr, o, x, poseOptions().out_of_plane, out);
}

std::vector<Match> Estimator::Impl::searchByProjection(const Features& f, const Eigen::Vector3d& x,
                                                       double radius_scale) {
  std::vector<Match> matches;
  std::vector<int> best_dist(f.size(), 256);
  std::vector<std::int64_t> best_point(f.size(), -1);
  const Eigen::Isometry3d T_c_w = T_w_c(x).inverse();
  for (auto& [id, p] : points) {
    const Eigen::Vector3d P_c = T_c_w * p.P;
    const double d = P_c.norm();
    if (P_c.z() < 0.1 || d > 3 * p.distance || d < p.distance / 3) continue;
    Eigen::Vector3d h;  // (u, v, u_R); mono: (u, v, unused)
    if (!predict(x, p.P, &h)) continue;
    if (h.x() < 0 || h.y() < 0 || h.x() >= rig.width || h.y() >= rig.height) continue;
    ++p.visible;
    const int level = predictLevel(p, d);
    const float r = static_cast<float>(opt.search_radius * radius_scale * std::pow(opt.scale_factor, level));
    BestTwo match;
    for (int i : f.near(static_cast<float>(h.x()), static_cast<float>(h.y()), r, level - 1, level + 1)) {
      if (rig.sensor != Sensor::kMono && f.u_right[i] >= 0 && std::fabs(f.u_right[i] - h.z()) > r) continue;
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

std::optional<Eigen::Vector3d> Estimator::Impl::relocalise(const Features& f) {
  if (rig.sensor == Sensor::kMono) return std::nullopt;
  // A seed: the projection search and the pose optimisation after it decide.
  const std::size_t enough = static_cast<std::size_t>(opt.tracking.min_inliers);
  std::vector<std::uint64_t> ids;
  cv::Mat map_descriptors;
  for (const auto& [id, p] : points) {
    if (!isTrusted(id) || rejected(kernelAlpha(id))) continue;
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
    const Eigen::Vector3d P_b = rig.T_b_c * (f.depth[i] * rig.camera->unproject(Eigen::Vector2d(kp.pt.x, kp.pt.y)));
    const Eigen::Vector3d& P_w = points.at(ids[knn[k][0].trainIdx]).P;
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

std::vector<PoseObservation> Estimator::Impl::poseObservations(const Features& f,
                                                               const std::vector<Match>& matches) const {
  std::vector<PoseObservation> obs(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) {
    PoseObservation& o = obs[k];
    o.P_w = points.at(matches[k].point).P;
    o.z = observation(f, matches[k].feature);
    o.stereo = hasStereo(f, matches[k].feature);
    o.sigma_px = opt.sigma_px * std::pow(opt.scale_factor, f.keypoints[matches[k].feature].octave);
    o.alpha = kernelAlpha(matches[k].point);
    // With the adaptive kernel a landmark any label has called dynamic does not place a frame,
    // though its alpha (0.51 after one person label, by the weights of ReliabilityParams) keeps
    // it in the map: a frame's pose is cheap to get wrong the other way (the wheels carry it),
    // while walkers' landmarks, freshly labelled and given depth, may outnumber the static ones
    // (dynamic 30 s cut, 8-10 s: a 0.4 deg yaw error; 0.135 -> 0.058 % of the path). Beyond
    // the paper, which weighs every landmark by its alpha alone. Huber and a fixed alpha know
    // nothing of labels.
    o.usable = !rejected(o.alpha) && (opt.kernel != KernelChoice::kAdaptive || isTrusted(matches[k].point));
  }
  return obs;
}

int Estimator::Impl::optimisePose(const Features& f, const std::vector<Match>& matches,
                                  const std::optional<WheelEdge>& prior, const Eigen::Vector3d& x_prev,
                                  Eigen::Vector3d* x, std::vector<char>* inlier, std::vector<double>* errors) {
  const WheelPrior wheel{prior ? &*prior : nullptr, x_prev};
  PlanarPoseResult r = optimisePlanarPose(mono_edge, stereo_edge ? &*stereo_edge : nullptr,
                                          poseObservations(f, matches), wheel, poseOptions(), x);
  inlier->swap(r.inlier);
  errors->swap(r.error);
  return r.inliers;
}

std::optional<WheelDelta> Estimator::Impl::wheelDelta(double t0, double t1) {
  std::lock_guard<std::mutex> lock(odometry_mutex);
  if (!has_odometry || opt.mode == Mode::kVo || odometry.empty()) return std::nullopt;
  t0 = std::max(t0, odometry.firstTime());
  t1 = std::min(t1, odometry.lastTime());
  if (!(t1 > t0)) return std::nullopt;
  return odometry.integrate(t0, t1, calibration.c);
}

void Estimator::Impl::processFrame(const FrameInput& in, std::future<FrontEnd> front_end) {
  FrameWork w;
  w.t = in.timestamp;
  // Labels that have come (threaded): applied now rather than at the next local BA, a keyframe
  // or more later, so that a walker's fresh landmarks stop counting as vision sooner.
  if (async) applyLabels(false);
  waitForMappingLag(w.t);
  predictFrame(&w);
  FrameRecord record{w.t, 0, SE2(), false};
  if (opt.mode == Mode::kWheel) {
    {
      std::lock_guard<std::mutex> lock(map_mutex);
      if (final_pose.empty()) final_pose[0] = SE2();  // the world's origin
    }
    record.ref_kf = 0;
    record.T_kf_b = w.predicted;
    finishFrame(record, w.t);
    return;
  }
  FrontEnd fe = front_end.valid() ? front_end.get() : frontEnd(in);
  w.f = std::move(fe.f);
  w.raw_image = fe.raw_image;

  std::unique_lock<std::mutex> lock(map_mutex);
  if (keyframes.empty() && final_pose.empty()) {
    // The first keyframe at the world's origin, points from stereo or depth (metric: no visual
    // initialisation to check against the wheels).
    const int made = createKeyFrame(w.t, Eigen::Vector3d::Zero(), std::move(w.f), {}, w.raw_image);
    record.ref_kf = next_kf - 1;
    record.visual = made > 0;
    lock.unlock();
    queueKeyFrame(w.t);
    finishFrame(record, w.t);
    return;
  }
  trackLocalMap(&w);
  if (!w.visual && !last_visual) relocaliseBlindFrame(&w);
  settleFrame(&w);
  const bool make_kf = keepFrame(&w, &record);
  lock.unlock();
  if (make_kf) queueKeyFrame(w.t);
  last_visual = w.visual;
  finishFrame(record, w.t);
}

void Estimator::Impl::predictFrame(FrameWork* w) {
  if (!has_last) return;
  {
    std::lock_guard<std::mutex> lock(map_mutex);
    const FrameRecord& prev = frames.back();
    last_pose = kfPose(prev.ref_kf) * prev.T_kf_b;
  }
  w->delta = wheelDelta(last_t, w->t);
  w->predicted = w->delta ? last_pose * w->delta->pose() : last_pose * (opt.mode == Mode::kVo ? velocity : SE2());
}

void Estimator::Impl::trackLocalMap(FrameWork* w) {
  auto t2 = Clock::now();
  w->x = w->predicted.vector();
  w->matches = searchByProjection(w->f, w->x, last_visual ? 1.0 : 2.0);
  if (static_cast<int>(w->matches.size()) < 2 * opt.tracking.min_inliers && !w->delta) {
    w->matches = searchByProjection(w->f, w->x, 3.0);  // no wheels: the motion model may be far off
  }
  timings.add("match", msSince(t2));
  auto t3 = Clock::now();
  // Vision counts only landmarks no label has called dynamic (in the slip test and for a visual
  // frame): a walker close in front fills the view with its own landmarks.
  w->trusted = trustedOf(w->matches);
  FrameDecision d = arbiter.decide(frameEvidence(*w));
  w->x = d.x;
  w->inliers = d.result.inliers;
  w->inlier = std::move(d.result.inlier);
  w->errors = std::move(d.result.error);
  w->strained = d.strained;
  if (d.slip) recordSlip(w->t, d.spin);
  if (d.gated) ++counters.wheel_gated;
  timings.add("pose", msSince(t3));
  w->visual = d.visual();
}

FrameEvidence Estimator::Impl::frameEvidence(const FrameWork& w) {
  FrameEvidence e;
  e.t = w.t;
  e.mono = &mono_edge;
  e.stereo = stereo_edge ? &*stereo_edge : nullptr;
  if (!w.matches.empty()) e.observations = poseObservations(w.f, w.matches);
  e.trusted = w.trusted;
  if (opt.mode == Mode::kVw) e.wheels = w.delta;
  e.x_prev = last_pose.vector();
  e.t_prev = last_t;
  e.x_guess = w.x;
  // Coming back from the wheels, vision must be convincingly back (the first frames after a
  // blackout carry few, poorly placed matches: one such frame put the pose 6 cm off).
  e.after_blind = !last_visual;
  e.wheels_between = [this](double t0, double t1) { return wheelDelta(t0, t1); };
  return e;
}

ArbiterOptions Estimator::Impl::arbiterOptions(const Rig& r, const EstimatorOptions& o) {
  ArbiterOptions a = ArbiterOptions::estimator(r.sensor == Sensor::kMono).apply(o.tracking);
  a.wheel_gate = a.wheel_gate && o.kernel == KernelChoice::kAdaptive;
  a.pose.huber = o.kernel == KernelChoice::kHuber;
  return a;
}

void Estimator::Impl::recordSlip(double t, bool spin) {
  ++slip_frames;
  markSlip(t, spin);
}

void Estimator::Impl::markSlip(double t, bool spin) {
  std::lock_guard<std::mutex> slock(slip_mutex);
  slip_marks.push_back({t, spin});
}

void Estimator::Impl::relocaliseBlindFrame(FrameWork* w) {
  auto t5 = Clock::now();
  if (const std::optional<Eigen::Vector3d> x_map = relocalise(w->f)) {
    w->x = *x_map;
    w->matches = searchByProjection(w->f, w->x, 1.0);
    w->matches.erase(
        std::remove_if(w->matches.begin(), w->matches.end(), [&](const Match& m) { return !isTrusted(m.point); }),
        w->matches.end());
    w->inliers = optimisePose(w->f, w->matches, std::nullopt, w->x, &w->x, &w->inlier, &w->errors);
    w->trusted = trustedOf(w->matches);
    w->visual =
        arbiter.believeRelocalisation(w->x, w->countTrusted(w->inlier), [&] { return onTheWheelsWay(w->x, w->t); });
    if (w->visual) ++counters.relocalisations;
  }
  timings.add("relocalise", msSince(t5));
}

void Estimator::Impl::settleFrame(FrameWork* w) {
  const FrameOutcome o = arbiter.settle(w->visual);
  w->after_slip = o.held;
  w->wheels_doubted = o.wheels_doubted;
  // Held still while the wheels went on, as far as the map knows: a spin, whose wheel edge sits
  // out local BA's first round and comes back in the second only if vision's keyframes agree
  // with it (docs/decisions/0003).
  if (o.held) markSlip(w->t, true);
}

bool Estimator::Impl::keepFrame(FrameWork* w, FrameRecord* record) {
  const SE2 T_w_b = w->visual ? SE2::fromVector(w->x) : w->after_slip ? last_pose : w->predicted;
  std::vector<std::int64_t> point_of(w->f.size(), -1);
  if (w->visual) {
    for (std::size_t k = 0; k < w->matches.size(); ++k) {
      if (!w->inlier[k]) continue;
      MapPoint& p = points.at(w->matches[k].point);
      ++p.found;
      point_of[w->matches[k].feature] = static_cast<std::int64_t>(p.id);
    }
  }
  // Eq. 6: every matched landmark's latest whitened error (outliers included: that is the point).
  if (w->visual && opt.kernel == KernelChoice::kAdaptive) {
    for (std::size_t k = 0; k < w->matches.size(); ++k)
      reliability.observe(w->matches[k].point, std::nullopt, w->errors[k]);
  }
  if (w->visual && !last_visual && has_last) spreadCorrection(T_w_b * w->predicted.inverse(), w->t);
  // Features matched to an untrusted landmark (adaptive kernel): a walker's, or one whose labels
  // are still to come. They neither ask for a keyframe (a walker close in front is forever
  // "close and untracked") nor give it a second, fresh landmark of the same walker.
  std::vector<char> on_walker(w->f.size(), 0);
  if (opt.kernel == KernelChoice::kAdaptive) {
    for (std::size_t k = 0; k < w->matches.size(); ++k) on_walker[w->matches[k].feature] |= !w->trusted[k];
  }
  ++frames_since_kf;
  const std::uint64_t ref = std::prev(keyframes.end())->first;
  const KeyFrame& ref_kf = keyframes.at(ref);
  const bool make_kf = keyFrameDue(*w, T_w_b, point_of, on_walker, ref_kf);
  if (make_kf) {
    auto t4 = Clock::now();
    std::vector<std::pair<int, std::uint64_t>> label_only;
    for (std::size_t k = 0; w->visual && k < w->matches.size(); ++k) {
      if (!w->inlier[k]) label_only.emplace_back(w->matches[k].feature, w->matches[k].point);
    }
    createKeyFrame(w->t, T_w_b.vector(), std::move(w->f), point_of, w->raw_image, w->inliers, on_walker);
    keyframes.at(next_kf - 1).label_only = std::move(label_only);
    record->ref_kf = next_kf - 1;
    record->T_kf_b = SE2();
    timings.add("keyframe", msSince(t4));
  } else {
    record->ref_kf = ref;
    record->T_kf_b = SE2::fromVector(ref_kf.x).inverse() * T_w_b;
  }
  record->visual = w->visual;
  record->slip = w->visual && arbiter.slipping();
  return make_kf;
}

bool Estimator::Impl::keyFrameDue(const FrameWork& w, const SE2& T_w_b, const std::vector<std::int64_t>& point_of,
                                  const std::vector<char>& on_walker, const KeyFrame& ref_kf) {
  int close_tracked = 0, close_untracked = 0;
  const double close = opt.max_depth_baselines * rig.baseline;
  for (std::size_t i = 0; i < w.f.size(); ++i) {
    if (w.f.depth[i] <= 0 || w.f.depth[i] > close || (point_of[i] < 0 && on_walker[i])) continue;
    (point_of[i] >= 0 ? close_tracked : close_untracked)++;
  }
  if (w.visual) {
    return frames_since_kf >= opt.keyframe_max_frames ||
           (frames_since_kf >= 2 && w.inliers < opt.keyframe_ratio * ref_kf.tracked) ||
           (!arbiter.slipping() && !w.strained && close_tracked < 100 && close_untracked > 70);
  }
  if (rig.sensor == Sensor::kMono) {
    // Mono: once the wheels have moved the camera far enough for a baseline.
    return (T_w_c(T_w_b.vector()).translation() - T_w_c(ref_kf.x).translation()).norm() >= opt.mono_min_baseline &&
           static_cast<int>(w.f.size()) >= 4 * opt.tracking.min_inliers;
  }
  const int with_depth =
      static_cast<int>(std::count_if(w.f.depth.begin(), w.f.depth.end(), [](float d) { return d > 0; }));
  // Not while the landmarks in view say the wheels are wrong (FrameOutcome::wheels_doubted): a map
  // restarted there is the slip's. As the wheels run away from the map its landmarks leave the
  // projection search, so the doubt outlasts the frames that raised it by Tracking.SlipHold.
  return frames_since_kf >= 3 && with_depth >= 4 * opt.tracking.min_inliers && !w.after_slip && !w.wheels_doubted;
}

bool Estimator::Impl::onTheWheelsWay(const Eigen::Vector3d& x, double t) {
  std::size_t j = frames.size();
  while (j > 0 && !(frames[j - 1].visual && !frames[j - 1].slip)) --j;
  if (j == 0) return true;
  const FrameRecord& v = frames[j - 1];
  const std::optional<WheelDelta> stretch = wheelDelta(v.t, t);
  if (!stretch || stretch->t0 > v.t + 1e-6) return true;  // no readings over the whole stretch to hold it to
  return onTheClaimedWay(*stretch, (kfPose(v.ref_kf) * v.T_kf_b).inverse() * SE2::fromVector(x));
}

void Estimator::Impl::spreadCorrection(const SE2& C, double t) {
  std::size_t first = frames.size();
  while (first > 0 && !frames[first - 1].visual) --first;
  if (first == frames.size() || first == 0) return;
  const double t0 = frames[first - 1].t;
  const Eigen::Vector3d xi = C.log();
  for (std::size_t j = first; j < frames.size(); ++j) {
    FrameRecord& r = frames[j];
    const double s = (r.t - t0) / (t - t0);
    const SE2 T_w_kf = kfPose(r.ref_kf);
    r.T_kf_b = T_w_kf.inverse() * (SE2::exp(s * xi) * (T_w_kf * r.T_kf_b));
  }
}

void Estimator::Impl::finishFrame(const FrameRecord& record, double t) {
  PoseEstimate pe;
  {
    std::lock_guard<std::mutex> lock(map_mutex);
    frames.push_back(record);
    const SE2 pose = kfPose(record.ref_kf) * record.T_kf_b;
    if (has_last) velocity = last_pose.inverse() * pose;
    last_pose = pose;
    pe = {t, pose, record.visual};
    if (!record.visual && opt.mode != Mode::kWheel) {
      ++counters.wheel_only_frames;
      auto& iv = counters.wheel_only_intervals;
      const double dt = 1.5 / rig.fps;
      if (!iv.empty() && t - iv.back().second <= dt) {
        iv.back().second = t;
      } else {
        iv.emplace_back(t, t);
      }
    }
  }
  last_t = t;
  has_last = true;
  if (callback) callback(pe);
}

void Estimator::Impl::drain(bool all) {
  // A frame waits until the odometry has passed its time (so its prediction has the readings
  // that straddle it), for at most a second of frames.
  // With a front end running ahead, a frame is also held until the next one has come, so that
  // the next one's features are made while this one is tracked (a frame's latency more).
  const std::size_t lookahead = front_end_queue ? 1 : 0;
  while (pending.size() > (all ? 0 : lookahead)) {
    const double t = pending.front().in.timestamp;
    bool ready = all || opt.mode == Mode::kVo || pending.size() > static_cast<std::size_t>(rig.fps) + 1;
    if (!ready) {
      std::lock_guard<std::mutex> lock(odometry_mutex);
      ready = !odometry.empty() && odometry.lastTime() >= t;
    }
    if (!ready) break;
    PendingFrame next = std::move(pending.front());
    pending.pop_front();
    const auto t0 = Clock::now();
    processFrame(next.in, std::move(next.front_end));
    timings.add("tracking", msSince(t0));  // the frame's whole turn, its waits included
  }
}

}  // namespace rvwo::estimator
