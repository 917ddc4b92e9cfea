// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "replay/orbslam3_backend.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;

// ORB-SLAM3 aborts on some failures (Sophus's checks, e.g. "SO3::exp failed" on a NaN pose):
// one line saying so instead of a bare "Aborted".
char g_abort_message[1024];
extern "C" void orbslam3Aborted(int) {
  const ssize_t n = ::write(STDERR_FILENO, g_abort_message, std::strlen(g_abort_message));
  (void)n;
  std::_Exit(1);
}

}  // namespace

OrbSlam3Backend::OrbSlam3Backend(const estimator::Rig& rig, const estimator::EstimatorOptions& opt, bool wheels,
                                 const Settings& settings, const std::string& vocabulary, const std::string& out,
                                 const std::shared_ptr<Segmenter>& segmenter)
    : T_b_c_(rig.T_b_c) {
  using Sensor = orbslam3::RunnerOptions::Sensor;
  const bool distorted = rig.radtan != std::array<double, 5>{};
  if (rig.rectification && (!distorted || rig.sensor == estimator::Sensor::kStereo))
    throw std::invalid_argument(
        "--backend orbslam3 takes a pinhole camera (mono or RGB-D, distorted or not) or a rectified pinhole stereo "
        "pair, not a fisheye pair");
  orbslam3::RunnerOptions o;
  o.sensor = rig.sensor == estimator::Sensor::kStereo ? Sensor::kStereo
             : rig.sensor == estimator::Sensor::kRgbd ? Sensor::kRgbd
                                                      : Sensor::kMono;
  o.vocabulary = vocabulary;
  o.settings = fs::path(out).replace_extension(".orbslam3.yaml").string();
  o.log = fs::path(out).replace_extension(".orbslam3.log").string();
  orbslam3::OrbSlam3Camera c;
  c.fx = rig.camera->fx();
  c.fy = rig.camera->fy();
  c.cx = rig.camera->cx();
  c.cy = rig.camera->cy();
  c.width = rig.width;
  c.height = rig.height;
  c.fps = rig.fps;
  c.baseline = rig.baseline;
  c.radtan = rig.radtan;  // the images go to ORB-SLAM3 as the camera gave them
  orbslam3::OrbSlam3Features f;
  f.features = opt.features;
  f.scale_factor = opt.scale_factor;
  orbslam3::WheelInputParams w;
  w.T_b_c = rig.T_b_c;
  w.T_b_o = rig.T_b_o.isometry3();
  w.radius_left = opt.drive.radius_left;
  w.radius_right = opt.drive.radius_right;
  w.track = opt.drive.track;
  w.huber = opt.kernel == estimator::KernelChoice::kHuber;
  w.tracking = readTrackingOptions(settings, w.tracking);  // Tracking.*, over the plugin's defaults
  w.calibrate = opt.calibrate;
  if (const auto v = settings.number("LocalMapping.Planar")) w.local_map = *v != 0;
  if (const auto v = settings.number("LocalMapping.MaxWheelSpan")) w.max_wheel_span = *v;
  w.spin_min_frames = w.tracking.slip_hold_min_frames;  // one key for both hosts: Tracking.SlipHoldMinFrames
  std::vector<std::pair<std::string, std::string>> more;
  for (const char* prefix :
       {"Odometry.Noise", "Odometry.CalibrateDistance", "Odometry.CalibrationConstant", "Reliability.", "Semantics.",
        "LoopClosing.", "Initializer.", "ORBextractor.AlignedPyramid"}) {
    for (const std::string& key : settings.keysWithPrefix(prefix)) {
      if (key == "Semantics.LabelSet") {  // the texts among them
        if (const auto t = settings.text(key)) more.emplace_back(key, "\"" + *t + "\"");
      } else if (key == "Semantics.PriorsFile") {  // relative to the sequence's settings
        if (const auto f = settings.file(key)) more.emplace_back(key, "\"" + *f + "\"");
      } else if (const auto v = settings.number(key)) {
        more.emplace_back(key, std::to_string(*v));
      }
    }
  }
  more.emplace_back("Segmentation.LabelDilation", std::to_string(opt.label_dilation_px));
  more.emplace_back("Segmentation.Model", "\"none\"");  // the replay's own segmenter, given below, or none
  // Without the wheels, RVWO's vision (labels, kernels) runs in ORB-SLAM3's tracking when a
  // segmenter gives labels; otherwise ORB-SLAM3 runs as upstream.
  const bool rvwo_vision = !wheels && segmenter;
  w.wheels = wheels;
  orbslam3::writeOrbSlam3Settings(o.settings, o.sensor, c, f, wheels || rvwo_vision ? &w : nullptr, more);
  std::printf("rvwo-replay: ORB-SLAM3 settings %s, its console output in %s\n", o.settings.c_str(), o.log.c_str());
  std::snprintf(g_abort_message, sizeof g_abort_message,
                "\nrvwo-replay: error: ORB-SLAM3 aborted (its last words are in %s); no trajectory written\n",
                o.log.c_str());
  std::signal(SIGABRT, orbslam3Aborted);
  runner_ = std::make_unique<orbslam3::Runner>(o);
  // Keyframes to the segmenter, labels into tracking's reliabilities (patch 0005).
  if (segmenter) runner_->setSegmenter(segmenter);
  scratch_ = fs::path(out).replace_extension(".orbslam3-").string();
}

Trajectory OrbSlam3Backend::finish(estimator::Report* rep) {
  const auto result = runner_->finish(scratch_);
  Trajectory out;
  for (const auto& [t, T_c0_c] : result.T_c0_c) out.push_back({t, T_b_c_ * T_c0_c * T_b_c_.inverse()});
  rep->frames = track_ms_.size();
  rep->keyframes = result.keyframes;
  rep->wheel_only_frames = result.wheel_only_frames;
  rep->wheel_only_intervals = result.wheel_only_intervals;
  rep->slip_frames = result.slip_frames;
  rep->segmented_keyframes = result.segmented_keyframes;
  rep->wheel_calibration = result.wheel_calibration;
  local_maps_ = result.local_maps;
  calibrated_local_maps_ = result.calibrated_local_maps;
  rep->timings = {{"TrackFrame", estimator::TimingStats::of(track_ms_)}};
  return out;
}

bool OrbSlam3Backend::track(const estimator::FrameInput& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool ok = runner_->track(f.timestamp, f.image, f.right.empty() ? f.depth : f.right);
  track_ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  frame_t_.push_back(f.timestamp);
  if (!ok) {
    if (lost_.empty() || lost_.back().second != last_t_) lost_.emplace_back(f.timestamp, f.timestamp);
    lost_.back().second = f.timestamp;
    ++lost_frames_;
  }
  last_t_ = f.timestamp;
  return ok;
}

}  // namespace rvwo::apps
