// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "mapper.h"

#include <cmath>
#include <string>
#include <unordered_map>

#include "rvwo/semantics/label_lookup.h"

namespace rvwo::estimator {

Mapper::Mapper(Context& ctx, Map& map, Wheels& wheels, std::shared_ptr<Segmenter> segmenter)
    : ctx_(ctx), map_(map), wheels_(wheels), segmenter_(ctx.opt.semantics ? std::move(segmenter) : nullptr) {
  if (labelsLater(ctx.opt, segmenter_.get())) async_ = std::make_unique<AsyncSegmenter>(segmenter_, 4, 256);
  dynamic_labels_ = ctx.opt.priors.dynamicLabels();
  if (!ctx.opt.deterministic) thread_ = std::thread([this] { mappingLoop(); });
}

Mapper::~Mapper() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Mapper::askForLabels(const KeyFrame& kf) {
  if (async_) async_->submit(kf.image, FrameInfo{kf.id, kf.t});
}

void Mapper::queueKeyFrame(double kf_t) {
  if (ctx_.opt.deterministic) {
    mapKeyFrame();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    pending_keyframe_ = true;
    queued_kf_t_ = kf_t;
  }
  queue_cv_.notify_one();
}

void Mapper::mappingLoop() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return stop_ || pending_keyframe_; });
      if (!pending_keyframe_) return;  // stop_, and nothing left
      pending_keyframe_ = false;
      busy_ = true;
    }
    mapKeyFrame();
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void Mapper::waitForLag(double t) {
  if (ctx_.opt.deterministic || ctx_.rig.sensor != Sensor::kMono) return;
  std::unique_lock<std::mutex> lock(queue_mutex_);
  if ((pending_keyframe_ || busy_) && t - queued_kf_t_ > ctx_.opt.mono_max_mapping_lag) {
    const auto t0 = Clock::now();
    idle_cv_.wait(lock, [&] { return !pending_keyframe_ && !busy_; });
    ctx_.timings.add("wait for mapping", msSince(t0));  // the report's timings: how often, how long
  }
}

void Mapper::waitForIdle() {
  if (ctx_.opt.deterministic) return;
  std::unique_lock<std::mutex> lock(queue_mutex_);
  idle_cv_.wait(lock, [&] { return !pending_keyframe_ && !busy_; });
}

void Mapper::applyLabels(bool wait) {
  if (!segmenter_) return;
  struct Todo {
    std::uint64_t id;
    double t;
    cv::Mat image;
  };
  std::vector<Todo> todo;
  {
    std::lock_guard<std::mutex> lock(map_.mutex);
    for (auto& [id, kf] : map_.keyframes) {
      if (!kf.segmented && !kf.image.empty()) todo.push_back({id, kf.t, kf.image});
    }
  }
  for (auto& [id, t, image] : todo) {
    std::optional<Segmentation> seg;
    std::string failure;
    auto t0 = Clock::now();
    if (!async_) {
      try {
        seg = segmenter_->segment(image, FrameInfo{id, t});
      } catch (const std::exception& e) {
        failure = e.what();
      }
    } else {
      // (Its failures are counted by the runner: report().)
      seg = wait ? async_->waitFor(id, std::chrono::milliseconds(2000)) : async_->take(id);
      // Still to come; dropped or failed ones never will: the keyframe is done with (its points
      // trusted, as unlabelled ones are).
      if (!seg && !wait && async_->pending(id)) continue;
    }
    if (!async_) ctx_.timings.add("segmentation", msSince(t0));
    // Labels of another size than the image they label would be looked up at the wrong pixels.
    if (seg && seg->labels.size() != image.size()) {
      failure = "label image " + std::to_string(seg->labels.cols) + "x" + std::to_string(seg->labels.rows) +
                " for a camera image " + std::to_string(image.cols) + "x" + std::to_string(image.rows);
      seg.reset();
    }
    std::lock_guard<std::mutex> lock(map_.mutex);
    if (!failure.empty() && map_.counters.segmentation_failures++ == 0)
      map_.counters.segmentation_error = "keyframe at t = " + std::to_string(t) + ": " + failure;
    auto it = map_.keyframes.find(id);
    if (it == map_.keyframes.end()) continue;
    KeyFrame& kf = it->second;
    kf.segmented = true;
    kf.image.release();
    if (!seg) continue;
    ++map_.counters.segmented_keyframes;
    if (ctx_.rig.rectification) {  // labels of the raw image, onto the rectified one
      seg->labels = ctx_.rig.rectification->rectifyLeftLabels(seg->labels);
      seg->confidence.release();  // (the lookup does not use it)
    }
    const LabelLookup lookup(*seg, dynamic_labels_, ctx_.opt.label_dilation_px);
    for (std::size_t i = 0; i < kf.f.size(); ++i) {
      if (kf.point[i] < 0) continue;
      const int label = lookup.labelAt(kf.f.keypoints[i].pt);
      if (label < 0) continue;
      map_.reliability.observe(static_cast<std::uint64_t>(kf.point[i]), ctx_.opt.priors.prior(label), std::nullopt);
    }
    // A walker's landmarks fail the gate as soon as it moves: its label must still reach them
    // (eqs. 4, 5), or they would keep alpha near 1 until culled and come back to hurt.
    for (const auto& [feature, point] : kf.label_only) {
      const int label = lookup.labelAt(kf.f.keypoints[feature].pt);
      if (label >= 0 && map_.points.count(point))
        map_.reliability.observe(point, ctx_.opt.priors.prior(label), std::nullopt);
    }
    kf.label_only.clear();
  }
}

void Mapper::mapKeyFrame() {
  auto t0 = Clock::now();
  applyLabels(ctx_.opt.deterministic);
  map_.cullPoints();
  localBundleAdjustment();
  if (const std::optional<double> oldest = map_.dropOldKeyFrames()) wheels_.dropBefore(*oldest);
  ctx_.timings.add("local mapping", msSince(t0));
}

WindowProblem Mapper::windowProblem(std::vector<std::uint64_t>* kf_ids, std::vector<std::uint64_t>* point_ids,
                                    std::vector<int>* features) const {
  WindowProblem pb;
  std::vector<std::uint64_t> all;
  for (const auto& kv : map_.keyframes) all.push_back(kv.first);
  const std::size_t first_var =
      all.size() > static_cast<std::size_t>(ctx_.opt.window) ? all.size() - ctx_.opt.window : 0;
  std::unordered_map<std::uint64_t, std::size_t> kf_index, point_index;
  auto addKeyFrame = [&](std::uint64_t id, bool fixed) {
    kf_index[id] = kf_ids->size();
    kf_ids->push_back(id);
    const KeyFrame& kf = map_.keyframes.at(id);
    pb.keyframes.push_back({kf.x, kf.t, fixed});
  };
  const std::size_t from = first_var > 0 ? first_var - 1 : 0;
  for (std::size_t i = from; i < all.size(); ++i) addKeyFrame(all[i], i == from);
  for (std::size_t i = first_var; i < all.size(); ++i) {
    const KeyFrame& kf = map_.keyframes.at(all[i]);
    for (std::size_t j = 0; j < kf.f.size(); ++j) {
      if (kf.point[j] < 0) continue;
      const std::uint64_t pid = static_cast<std::uint64_t>(kf.point[j]);
      if (point_index.count(pid)) continue;
      const double a = map_.kernelAlpha(pid);
      if (ctx_.rejected(a)) continue;
      point_index[pid] = point_ids->size();
      point_ids->push_back(pid);
      pb.points.push_back({map_.points.at(pid).P, a});
    }
  }
  // Observations of those points by keyframes in the problem; others in memory join fixed.
  for (std::size_t pi = 0; pi < point_ids->size(); ++pi) {
    for (const auto& [kf_id, feature] : map_.points.at((*point_ids)[pi]).obs) {
      if (!kf_index.count(kf_id)) {
        if (!map_.keyframes.count(kf_id)) continue;
        addKeyFrame(kf_id, true);
      }
      const Features& f = map_.keyframes.at(kf_id).f;
      const int level = f.keypoints[feature].octave;
      pb.observations.push_back({static_cast<int>(kf_index.at(kf_id)), static_cast<int>(pi),
                                 Context::observation(f, feature), ctx_.hasStereo(f, feature), ctx_.sigmaAt(level)});
      features->push_back(feature);
    }
  }
  return pb;
}

void Mapper::addWheelEdges(WindowProblem* pb, const std::vector<std::uint64_t>& kf_ids) const {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < kf_ids.size(); ++i) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return kf_ids[a] < kf_ids[b]; });
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const std::size_t a = order[k], b = order[k + 1];
    const WindowKeyFrame &ka = pb->keyframes[a], &kb = pb->keyframes[b];
    if (ka.fixed && kb.fixed) continue;
    const std::optional<WheelDelta> d = wheels_.delta(ka.t, kb.t);
    if (!d) continue;
    const Wheels::SlipCount slips = wheels_.slipsBetween(ka.t, kb.t);
    pb->wheels.push_back({static_cast<int>(a), static_cast<int>(b), *d, slips.frames > 0,
                          ctx_.rig.sensor != Sensor::kMono && slips.spins >= ctx_.opt.tracking.slip_hold_min_frames});
  }
}

WindowOptions Mapper::windowOptions() const {
  WindowOptions wo;
  wo.huber = ctx_.opt.kernel == KernelChoice::kHuber;
  wo.barron_scale = ctx_.opt.tracking.barron_scale;
  wo.out_of_plane = ctx_.opt.tracking.outOfPlane();
  wo.min_views = ctx_.rig.sensor == Sensor::kMono ? 2 : 1;  // a mono point needs two views for its depth
  wo.outliers_leave = true;
  wo.drop_slipping_wheel_edges = true;
  wo.slipped_wheel_chi2 = kChi2Stereo;
  wo.calibrate = ctx_.opt.mode == Mode::kVw && ctx_.opt.calibrate;
  // Mono has no metric but the wheels': scaling the window's map and the wheels' distance scale
  // together changes no residual (docs/decisions/0001).
  wo.hold_distance_scale = ctx_.rig.sensor == Sensor::kMono;
  wo.calibration_sigma = ctx_.opt.calibration_sigma;
  wo.calibration_step = ctx_.opt.calibration_step;
  wo.calibration_period = ctx_.opt.calibration_period;
  return wo;
}

void Mapper::localBundleAdjustment() {
  auto t0 = Clock::now();
  std::vector<std::uint64_t> kf_ids, point_ids;
  std::vector<int> features;
  WindowProblem pb;
  {
    std::lock_guard<std::mutex> lock(map_.mutex);
    if (map_.keyframes.size() < 2) return;
    pb = windowProblem(&kf_ids, &point_ids, &features);
  }
  if (ctx_.opt.mode == Mode::kVw) addWheelEdges(&pb, kf_ids);
  pb.calibration = wheels_.calibration();
  const WindowSolution sol = solveWindow(ctx_.mono_edge, ctx_.stereo(), pb, windowOptions());
  wheel_outliers_ += sol.wheel_edges_dropped;
  ctx_.timings.add("local BA", msSince(t0));
  std::lock_guard<std::mutex> lock(map_.mutex);
  if (!sol.usable) return;
  if (sol.calibrated) wheels_.refine(sol.calibration, sol.newest_t);
  writeBack(pb, sol, kf_ids, point_ids, features);
}

void Mapper::writeBack(const WindowProblem& pb, const WindowSolution& sol, const std::vector<std::uint64_t>& kf_ids,
                       const std::vector<std::uint64_t>& point_ids, const std::vector<int>& features) {
  for (std::size_t i = 0; i < kf_ids.size(); ++i) {
    if (pb.keyframes[i].fixed) continue;
    auto it = map_.keyframes.find(kf_ids[i]);
    if (it != map_.keyframes.end()) it->second.x = sol.x_w_b[i];
  }
  std::vector<double> sum(point_ids.size(), 0.0);
  std::vector<int> count(point_ids.size(), 0);
  for (std::size_t k = 0; k < pb.observations.size(); ++k) {
    const WindowObservation& o = pb.observations[k];
    sum[o.point] += std::min(sol.chi2[k], 1e4);
    ++count[o.point];
    if (sol.outlier[k]) {  // the observation goes
      const std::uint64_t kf_id = kf_ids[o.keyframe];
      auto p = map_.points.find(point_ids[o.point]);
      if (p != map_.points.end()) p->second.obs.erase(kf_id);
      auto kf = map_.keyframes.find(kf_id);
      if (kf != map_.keyframes.end()) kf->second.point[features[k]] = -1;
    }
  }
  for (std::size_t pi = 0; pi < point_ids.size(); ++pi) {
    auto p = map_.points.find(point_ids[pi]);
    if (p == map_.points.end()) continue;
    p->second.P = sol.P_w[pi];
    // Eq. 6: the landmark's RMS whitened error over the window.
    if (ctx_.opt.kernel == KernelChoice::kAdaptive && count[pi] > 0)
      map_.reliability.observe(point_ids[pi], std::nullopt, std::sqrt(sum[pi] / count[pi]));
  }
}

}  // namespace rvwo::estimator
