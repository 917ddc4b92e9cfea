// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Local mapping, in a thread of its own unless deterministic: for each keyframe tracking queues,
// the keyframes' labels (eqs. 4, 5), culling, the window bundle adjustment through
// rvwo::solveWindow, and retiring old keyframes. Only the newest keyframe is worth a local BA (the
// ones before it are in its window), so a flag is the whole queue. Private to the library.
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "map.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/tracking/window.h"
#include "wheels.h"

namespace rvwo::estimator {

class Mapper {
 public:
  // segmenter: none without semantics. Threaded (not deterministic), labels come from a thread of
  // their own too (labelsLater).
  Mapper(Context& ctx, Map& map, Wheels& wheels, std::shared_ptr<Segmenter> segmenter);
  ~Mapper();  // stops the thread, once it has done the keyframe under way

  static bool labelsLater(const EstimatorOptions& o, const Segmenter* segmenter) {
    return o.semantics && segmenter && !o.deterministic;
  }

  // A new keyframe's image goes to the segmenter (threaded).
  void askForLabels(const KeyFrame& kf);
  // Maps the keyframe made at kf_t: now (deterministic) or in the thread.
  void queueKeyFrame(double kf_t);
  // Mono tracking no further ahead of local mapping than Estimator.MonoMaxMappingLag of data
  // (threaded; options.h says why mono only).
  void waitForLag(double t);
  void waitForIdle();

  // Labels of keyframes still in memory that have not had theirs: semantic observations of their
  // points (eqs. 4, 5). wait: for those still being made (threaded).
  void applyLabels(bool wait);

  // Local BA over the window (rvwo::solveWindow), solved without the map lock, written back under
  // it: poses, points, outlier observations erased, each point's RMS error into its reliability
  // (eq. 6), the wheels' calibration if the window taught it.
  void localBundleAdjustment();

  std::size_t wheelOutliers() const { return wheel_outliers_; }  // wheel edges local BA found wrong
  const AsyncSegmenter* asyncSegmenter() const { return async_.get(); }
  bool labelled() const { return segmenter_ != nullptr; }  // keyframes get labels (semantics on, a segmenter)

 private:
  void mappingLoop();
  void mapKeyFrame();

  // The window's problem under the map lock: the last Estimator.Window keyframes free, the one
  // before them fixed (it carries the gauge and the wheel edge into the window; at the start, the
  // first keyframe), the points they see that the kernel does not reject, and every keyframe in
  // memory that sees those points, fixed. ids: the keyframes' and points' ids, in the problem's
  // order; features: per observation, the keyframe's feature. (Map lock held.)
  WindowProblem windowProblem(std::vector<std::uint64_t>* kf_ids, std::vector<std::uint64_t>* point_ids,
                              std::vector<int>* features) const;

  // Wheel edges between keyframes consecutive in time, one end at least free: Huber across a slip
  // tracking caught; across a spin (Tracking.SlipHoldMinFrames frames or more where the robot
  // about stood while the wheels went on) out of the first round, stereo and RGB-D only (mono's
  // window takes its scale from them; docs/decisions/0003).
  void addWheelEdges(WindowProblem* pb, const std::vector<std::uint64_t>& kf_ids) const;

  WindowOptions windowOptions() const;

  // (Map lock held.)
  void writeBack(const WindowProblem& pb, const WindowSolution& sol, const std::vector<std::uint64_t>& kf_ids,
                 const std::vector<std::uint64_t>& point_ids, const std::vector<int>& features);

  Context& ctx_;
  Map& map_;
  Wheels& wheels_;
  std::shared_ptr<Segmenter> segmenter_;
  std::unique_ptr<AsyncSegmenter> async_;
  std::vector<int> dynamic_labels_;
  std::atomic<std::size_t> wheel_outliers_{0};

  std::mutex queue_mutex_;
  std::condition_variable queue_cv_, idle_cv_;
  bool pending_keyframe_ = false;
  bool stop_ = false, busy_ = false;
  double queued_kf_t_ = -1e300;  // the time of the keyframe queued last
  std::thread thread_;           // started last: the loop reads every member above
};

}  // namespace rvwo::estimator
