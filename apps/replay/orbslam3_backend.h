// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// rvwo-replay's --backend orbslam3: a patched ORB-SLAM3 (patches/orbslam3/) fed the rawlog as RVWO's
// estimator is, its report in the same terms. Built only when CMake is given ORB_SLAM3_ROOT.
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rvwo/estimator/estimator.h"
#include "rvwo/orbslam3/runner.h"
#include "rvwo/semantics/segmenter.h"
#include "rvwo/settings/settings.h"
#include "support/trajectory.h"

namespace rvwo::apps {

// --backend orbslam3: ORB-SLAM3 (patched) fed like the estimator, its report in the same terms.
class OrbSlam3Backend {
 public:
  // settings: the sequence's, whose Odometry.Noise*, Odometry.Calibrate*, Reliability.*, Semantics.*,
  // Tracking.* (over the plugin's defaults), Initializer.*, LocalMapping.*, LoopClosing.* and
  // ORBextractor.AlignedPyramid keys go on to ORB-SLAM3 (and the label dilation, Segmentation.LabelDilation).
  // segmenter: the keyframes' (none: reliabilities from reprojection errors alone); without the
  // wheels, one given runs RVWO's vision (labels, kernels) in ORB-SLAM3's 6-DoF tracking, and
  // none leaves ORB-SLAM3 as upstream.
  OrbSlam3Backend(const estimator::Rig& rig, const estimator::EstimatorOptions& opt, bool wheels,
                  const Settings& settings, const std::string& vocabulary, const std::string& out,
                  const std::shared_ptr<Segmenter>& segmenter);
  // Frames wait for the wheel reading that reaches their time (in a rawlog it comes after them),
  // so that ORB-SLAM3 is given the wheels up to the frame; without wheels they go at once.
  // progress: called with each frame tracked.
  void addWheels(const orbslam3::WheelReading& r, const std::function<void(double, bool)>& progress) {
    runner_->addWheels(r);
    while (!waiting_.empty() && waiting_.front().timestamp <= r.t) {
      const bool ok = track(waiting_.front());
      progress(waiting_.front().timestamp, ok);
      waiting_.pop_front();
    }
  }
  void addFrame(const estimator::FrameInput& f, bool wheels, const std::function<void(double, bool)>& progress) {
    if (wheels) {
      waiting_.push_back(f);
      while (waiting_.size() > 30) {  // a second of frames without wheels: go on without them
        progress(waiting_.front().timestamp, track(waiting_.front()));
        waiting_.pop_front();
      }
    } else {
      progress(f.timestamp, track(f));
    }
  }
  void flush(const std::function<void(double, bool)>& progress) {
    for (; !waiting_.empty(); waiting_.pop_front()) progress(waiting_.front().timestamp, track(waiting_.front()));
  }

  // T_w_b per frame ORB-SLAM3 kept (w: the base at its first keyframe), and the report: with
  // wheels, the plugin's frames on the wheels and slips.
  Trajectory finish(estimator::Report* rep);
  // Frames ORB-SLAM3 did not track (lost, not initialised), and their stretches.
  std::size_t lostFrames() const { return lost_frames_; }
  // Local maps the plugin solved on SE(2), and those that refined the wheels' calibration.
  std::size_t localMaps() const { return local_maps_; }
  std::size_t calibratedLocalMaps() const { return calibrated_local_maps_; }
  const std::vector<std::pair<double, double>>& lost() const { return lost_; }
  const std::vector<double>& frameTimes() const { return frame_t_; }

 private:
  // Returns whether ORB-SLAM3 tracks after the frame.
  bool track(const estimator::FrameInput& f);

  Eigen::Isometry3d T_b_c_;
  std::unique_ptr<orbslam3::Runner> runner_;
  std::string scratch_;
  std::size_t lost_frames_ = 0;
  std::size_t local_maps_ = 0, calibrated_local_maps_ = 0;
  double last_t_ = NAN;
  std::vector<std::pair<double, double>> lost_;
  std::vector<double> track_ms_;
  std::vector<double> frame_t_;
  std::deque<estimator::FrameInput> waiting_;
};

}  // namespace rvwo::apps
