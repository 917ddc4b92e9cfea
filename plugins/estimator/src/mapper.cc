// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Local mapping: labels, culling and the window bundle adjustment, in a thread of its own.
#include "impl.h"

namespace rvwo::estimator {

void Estimator::Impl::stopMapper() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    stop = true;
  }
  queue_cv.notify_all();
  if (mapper.joinable()) mapper.join();
}

void Estimator::Impl::queueKeyFrame(double kf_t) {
  if (opt.deterministic) {
    mapKeyFrame();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    pending_keyframe = true;
    queued_kf_t = kf_t;
  }
  queue_cv.notify_one();
}

void Estimator::Impl::mappingLoop() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(queue_mutex);
      queue_cv.wait(lock, [&] { return stop || pending_keyframe; });
      if (!pending_keyframe) return;  // stop, and nothing left
      pending_keyframe = false;
      busy = true;
    }
    mapKeyFrame();
    {
      std::lock_guard<std::mutex> lock(queue_mutex);
      busy = false;
    }
    idle_cv.notify_all();
  }
}

void Estimator::Impl::waitForMappingLag(double t) {
  if (opt.deterministic || rig.sensor != Sensor::kMono) return;
  std::unique_lock<std::mutex> lock(queue_mutex);
  if ((pending_keyframe || busy) && t - queued_kf_t > opt.mono_max_mapping_lag) {
    const auto t0 = Clock::now();
    idle_cv.wait(lock, [&] { return !pending_keyframe && !busy; });
    timings.add("wait for mapping", msSince(t0));  // the report's timings: how often, how long
  }
}

void Estimator::Impl::waitForMapper() {
  if (opt.deterministic) return;
  std::unique_lock<std::mutex> lock(queue_mutex);
  idle_cv.wait(lock, [&] { return !pending_keyframe && !busy; });
}

void Estimator::Impl::applyLabels(bool wait) {
  if (!segmenter) return;
  struct Todo {
    std::uint64_t id;
    double t;
    cv::Mat image;
  };
  std::vector<Todo> todo;
  {
    std::lock_guard<std::mutex> lock(map_mutex);
    for (auto& [id, kf] : keyframes) {
      if (!kf.segmented && !kf.image.empty()) todo.push_back({id, kf.t, kf.image});
    }
  }
  for (auto& [id, t, image] : todo) {
    std::optional<Segmentation> seg;
    std::string failure;
    auto t0 = Clock::now();
    if (!async) {
      try {
        seg = segmenter->segment(image, FrameInfo{id, t});
      } catch (const std::exception& e) {
        failure = e.what();
      }
    } else {
      // (Its failures are counted by the runner: report().)
      seg = wait ? async->waitFor(id, std::chrono::milliseconds(2000)) : async->take(id);
      // Still to come; dropped or failed ones never will: the keyframe is done with (its points
      // trusted, as unlabelled ones are).
      if (!seg && !wait && async->pending(id)) continue;
    }
    if (!async) timings.add("segmentation", msSince(t0));
    // Labels of another size than the image they label would be looked up at the wrong pixels.
    if (seg && seg->labels.size() != image.size()) {
      failure = "label image " + std::to_string(seg->labels.cols) + "x" + std::to_string(seg->labels.rows) +
                " for a camera image " + std::to_string(image.cols) + "x" + std::to_string(image.rows);
      seg.reset();
    }
    std::lock_guard<std::mutex> lock(map_mutex);
    if (!failure.empty() && counters.segmentation_failures++ == 0)
      counters.segmentation_error = "keyframe at t = " + std::to_string(t) + ": " + failure;
    auto it = keyframes.find(id);
    if (it == keyframes.end()) continue;
    KeyFrame& kf = it->second;
    kf.segmented = true;
    kf.image.release();
    if (!seg) continue;
    ++counters.segmented_keyframes;
    if (rig.rectification) {  // labels of the raw image, onto the rectified one
      seg->labels = rig.rectification->rectifyLeftLabels(seg->labels);
      seg->confidence.release();  // (the lookup does not use it)
    }
    const LabelLookup lookup(*seg, dynamic_labels, opt.label_dilation_px);
    for (std::size_t i = 0; i < kf.f.size(); ++i) {
      if (kf.point[i] < 0) continue;
      const int label = lookup.labelAt(kf.f.keypoints[i].pt);
      if (label < 0) continue;
      reliability.observe(static_cast<std::uint64_t>(kf.point[i]), opt.priors.prior(label), std::nullopt);
    }
    // A walker's landmarks fail the gate as soon as it moves: its label must still reach them
    // (eqs. 4, 5), or they would keep alpha near 1 until culled and come back to hurt.
    for (const auto& [feature, point] : kf.label_only) {
      const int label = lookup.labelAt(kf.f.keypoints[feature].pt);
      if (label >= 0 && points.count(point)) reliability.observe(point, opt.priors.prior(label), std::nullopt);
    }
    kf.label_only.clear();
  }
}

void Estimator::Impl::mapKeyFrame() {
  auto t0 = Clock::now();
  applyLabels(opt.deterministic);
  cullPoints();
  localBundleAdjustment();
  dropOldKeyFrames();
  timings.add("local mapping", msSince(t0));
}

WindowProblem Estimator::Impl::windowProblem(std::vector<std::uint64_t>* kf_ids, std::vector<std::uint64_t>* point_ids,
                                             std::vector<int>* features) const {
  WindowProblem pb;
  std::vector<std::uint64_t> all;
  for (const auto& kv : keyframes) all.push_back(kv.first);
  const std::size_t first_var = all.size() > static_cast<std::size_t>(opt.window) ? all.size() - opt.window : 0;
  std::unordered_map<std::uint64_t, std::size_t> kf_index, point_index;
  auto addKeyFrame = [&](std::uint64_t id, bool fixed) {
    kf_index[id] = kf_ids->size();
    kf_ids->push_back(id);
    const KeyFrame& kf = keyframes.at(id);
    pb.keyframes.push_back({kf.x, kf.t, fixed});
  };
  const std::size_t from = first_var > 0 ? first_var - 1 : 0;
  for (std::size_t i = from; i < all.size(); ++i) addKeyFrame(all[i], i == from);
  for (std::size_t i = first_var; i < all.size(); ++i) {
    const KeyFrame& kf = keyframes.at(all[i]);
    for (std::size_t j = 0; j < kf.f.size(); ++j) {
      if (kf.point[j] < 0) continue;
      const std::uint64_t pid = static_cast<std::uint64_t>(kf.point[j]);
      if (point_index.count(pid)) continue;
      const double a = kernelAlpha(pid);
      if (rejected(a)) continue;
      point_index[pid] = point_ids->size();
      point_ids->push_back(pid);
      pb.points.push_back({points.at(pid).P, a});
    }
  }
  // Observations of those points by keyframes in the problem; others in memory join fixed.
  for (std::size_t pi = 0; pi < point_ids->size(); ++pi) {
    for (const auto& [kf_id, feature] : points.at((*point_ids)[pi]).obs) {
      if (!kf_index.count(kf_id)) {
        if (!keyframes.count(kf_id)) continue;
        addKeyFrame(kf_id, true);
      }
      const Features& f = keyframes.at(kf_id).f;
      const int level = f.keypoints[feature].octave;
      pb.observations.push_back({static_cast<int>(kf_index.at(kf_id)), static_cast<int>(pi), observation(f, feature),
                                 hasStereo(f, feature), opt.sigma_px * std::pow(opt.scale_factor, level)});
      features->push_back(feature);
    }
  }
  return pb;
}

void Estimator::Impl::addWheelEdges(WindowProblem* pb, const std::vector<std::uint64_t>& kf_ids) {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < kf_ids.size(); ++i) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return kf_ids[a] < kf_ids[b]; });
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const std::size_t a = order[k], b = order[k + 1];
    const WindowKeyFrame &ka = pb->keyframes[a], &kb = pb->keyframes[b];
    if (ka.fixed && kb.fixed) continue;
    const std::optional<WheelDelta> d = wheelDelta(ka.t, kb.t);
    if (!d) continue;
    const SlipCount slips = slipsBetween(ka.t, kb.t);
    pb->wheels.push_back({static_cast<int>(a), static_cast<int>(b), *d, slips.frames > 0,
                          rig.sensor != Sensor::kMono && slips.spins >= opt.tracking.slip_hold_min_frames});
  }
}

WindowOptions Estimator::Impl::windowOptions() const {
  WindowOptions wo;
  wo.huber = opt.kernel == KernelChoice::kHuber;
  wo.barron_scale = opt.tracking.barron_scale;
  wo.out_of_plane = opt.tracking.outOfPlane();
  wo.min_views = rig.sensor == Sensor::kMono ? 2 : 1;  // a mono point needs two views for its depth
  wo.outliers_leave = true;
  wo.drop_slipping_wheel_edges = true;
  wo.slipped_wheel_chi2 = kChi2Stereo;
  wo.calibrate = opt.mode == Mode::kVw && opt.calibrate;
  // Mono has no metric but the wheels': scaling the window's map and the wheels' distance scale
  // together changes no residual (docs/decisions/0001).
  wo.hold_distance_scale = rig.sensor == Sensor::kMono;
  wo.calibration_sigma = opt.calibration_sigma;
  wo.calibration_step = opt.calibration_step;
  wo.calibration_period = opt.calibration_period;
  return wo;
}

void Estimator::Impl::localBundleAdjustment() {
  auto t0 = Clock::now();
  std::vector<std::uint64_t> kf_ids, point_ids;
  std::vector<int> features;
  WindowProblem pb;
  {
    std::lock_guard<std::mutex> lock(map_mutex);
    if (keyframes.size() < 2) return;
    pb = windowProblem(&kf_ids, &point_ids, &features);
  }
  if (opt.mode == Mode::kVw) addWheelEdges(&pb, kf_ids);
  {
    std::lock_guard<std::mutex> lock(odometry_mutex);
    pb.calibration = calibration;
  }
  const WindowSolution sol = solveWindow(mono_edge, stereo_edge ? &*stereo_edge : nullptr, pb, windowOptions());
  wheel_outliers += sol.wheel_edges_dropped;
  timings.add("local BA", msSince(t0));
  std::lock_guard<std::mutex> lock(map_mutex);
  if (!sol.usable) return;
  if (sol.calibrated) {
    std::lock_guard<std::mutex> olock(odometry_mutex);
    calibration.refined(sol.calibration, sol.newest_t);
  }
  writeBack(pb, sol, kf_ids, point_ids, features);
}

void Estimator::Impl::writeBack(const WindowProblem& pb, const WindowSolution& sol,
                                const std::vector<std::uint64_t>& kf_ids, const std::vector<std::uint64_t>& point_ids,
                                const std::vector<int>& features) {
  for (std::size_t i = 0; i < kf_ids.size(); ++i) {
    if (pb.keyframes[i].fixed) continue;
    auto it = keyframes.find(kf_ids[i]);
    if (it != keyframes.end()) it->second.x = sol.x_w_b[i];
  }
  std::vector<double> sum(point_ids.size(), 0.0);
  std::vector<int> count(point_ids.size(), 0);
  for (std::size_t k = 0; k < pb.observations.size(); ++k) {
    const WindowObservation& o = pb.observations[k];
    sum[o.point] += std::min(sol.chi2[k], 1e4);
    ++count[o.point];
    if (sol.outlier[k]) {  // the observation goes
      const std::uint64_t kf_id = kf_ids[o.keyframe];
      auto p = points.find(point_ids[o.point]);
      if (p != points.end()) p->second.obs.erase(kf_id);
      auto kf = keyframes.find(kf_id);
      if (kf != keyframes.end()) kf->second.point[features[k]] = -1;
    }
  }
  for (std::size_t pi = 0; pi < point_ids.size(); ++pi) {
    auto p = points.find(point_ids[pi]);
    if (p == points.end()) continue;
    p->second.P = sol.P_w[pi];
    // Eq. 6: the landmark's RMS whitened error over the window.
    if (opt.kernel == KernelChoice::kAdaptive && count[pi] > 0)
      reliability.observe(point_ids[pi], std::nullopt, std::sqrt(sum[pi] / count[pi]));
  }
}

}  // namespace rvwo::estimator
