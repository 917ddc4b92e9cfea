// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The estimator's public interface, its options' checks and its report; the work is in
// front_end.cc, map.cc, tracker.cc and mapper.cc (impl.h).
#include "impl.h"

namespace rvwo::estimator {

double Rig::bf() const { return baseline * camera->fx(); }

TimingStats TimingStats::of(std::vector<double> ms) {
  TimingStats s;
  s.count = ms.size();
  if (ms.empty()) return s;
  std::sort(ms.begin(), ms.end());
  double sum = 0;
  for (double x : ms) sum += x;
  s.mean = sum / ms.size();
  s.p50 = ms[ms.size() / 2];
  s.p95 = ms[std::min(ms.size() - 1, static_cast<std::size_t>(0.95 * ms.size()))];
  s.max = ms.back();
  return s;
}

void EstimatorOptions::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("estimator options: " + what); };
  if (features < 50 || features > 20000) fail("Estimator.Features: 50 to 20000");
  if (!(scale_factor > 1.0 && scale_factor < 2.0)) fail("Estimator.ScaleFactor: in (1, 2)");
  if (levels < 1 || levels > 12) fail("Estimator.Levels: 1 to 12");
  if (fast_threshold < 1 || fast_threshold > 100) fail("Estimator.FastThreshold: 1 to 100");
  if (!(search_radius > 0)) fail("Estimator.SearchRadius: > 0");
  if (keyframe_max_frames < 1) fail("Estimator.KeyFrameMaxFrames: >= 1");
  if (!(keyframe_ratio > 0 && keyframe_ratio < 1)) fail("Estimator.KeyFrameRatio: in (0, 1)");
  if (window < 2) fail("Estimator.Window: >= 2");
  if (keep_keyframes < window + 1) fail("Estimator.KeepKeyFrames: > Estimator.Window");
  if (!(mono_max_mapping_lag >= 0)) fail("Estimator.MonoMaxMappingLag: >= 0 s");
  if (!(sigma_px > 0)) fail("Estimator.SigmaPx: > 0");
  if (!(mono_min_baseline > 0)) fail("Estimator.MonoMinBaseline: > 0");
  if (!(mono_min_parallax > 0 && mono_min_parallax < 45)) fail("Estimator.MonoMinParallax: in (0, 45) degrees");
  if (kernel == KernelChoice::kFixed && std::isnan(fixed_alpha)) fail("kernel fixed: alpha is NaN");
  if (!(calibration_period > 0)) fail("calibration_period: > 0 s");
  tracking.validate();
  reliability.validate();
  wheel_noise.validate();
  drive.validate();
}

Estimator::Estimator(const Rig& rig, const EstimatorOptions& options, std::shared_ptr<Segmenter> segmenter) {
  options.validate();
  if (!rig.camera) throw std::invalid_argument("estimator: the rig has no camera");
  // Mono takes its scale from the wheels: vision alone has none to give.
  if (rig.sensor == Sensor::kMono && options.mode == Mode::kVo)
    throw std::invalid_argument("estimator: a mono camera needs the wheels for its scale (--mode vw or wheel)");
  if (rig.sensor != Sensor::kMono && rig.camera->kind() != CameraModel::Kind::kPinhole)
    throw std::invalid_argument("estimator: stereo and RGB-D need a rectified pinhole camera");
  if (!(rig.baseline > 0)) throw std::invalid_argument("estimator: Stereo.b must be > 0");
  if (rig.width <= 0 || rig.height <= 0 || !(rig.fps > 0))
    throw std::invalid_argument("estimator: Camera.width, Camera.height and Camera.fps must be > 0");
  impl_ = std::make_unique<Impl>(rig, options, std::move(segmenter));
}

Estimator::~Estimator() = default;

void Estimator::addOdometryPose(double t, const SE2& T_odom_o) {
  {
    std::lock_guard<std::mutex> lock(impl_->odometry_mutex);
    impl_->odometry.addPose(t, T_odom_o);
    impl_->has_odometry = true;
  }
  impl_->drain(false);
}

void Estimator::addWheelAngles(double t, double q_left, double q_right) {
  {
    std::lock_guard<std::mutex> lock(impl_->odometry_mutex);
    impl_->odometry.addWheelAngles(t, q_left, q_right, impl_->opt.drive);
    impl_->has_odometry = true;
  }
  impl_->drain(false);
}

void Estimator::addWheelSpeeds(double t, double w_left, double w_right) {
  {
    std::lock_guard<std::mutex> lock(impl_->odometry_mutex);
    impl_->odometry.addWheelSpeeds(t, w_left, w_right, impl_->opt.drive);
    impl_->has_odometry = true;
  }
  impl_->drain(false);
}

void Estimator::addFrame(const FrameInput& frame) {
  Impl& s = *impl_;
  if (!std::isfinite(frame.timestamp) || frame.timestamp <= s.added_t)
    throw std::invalid_argument("frame at t = " + std::to_string(frame.timestamp) +
                                ": timestamp not after the previous frame's");
  auto checkImage = [&](const cv::Mat& m, const char* what) {
    if (m.empty()) throw std::invalid_argument(std::string("frame: no ") + what + " image");
    if (m.cols != s.rig.width || m.rows != s.rig.height)
      throw std::invalid_argument(std::string("frame: ") + what + " image is " + std::to_string(m.cols) + "x" +
                                  std::to_string(m.rows) + ", the settings say " + std::to_string(s.rig.width) + "x" +
                                  std::to_string(s.rig.height));
    if (m.depth() != CV_8U && std::string(what) != "depth")
      throw std::invalid_argument(std::string("frame: ") + what + " image is not 8-bit");
  };
  if (s.opt.mode != Mode::kWheel) {
    checkImage(frame.image, "camera");
    if (s.rig.sensor == Sensor::kStereo) checkImage(frame.right, "right");
    if (s.rig.sensor == Sensor::kRgbd) {
      checkImage(frame.depth, "depth");
      if (frame.depth.type() != CV_16U && frame.depth.type() != CV_32F)
        throw std::invalid_argument("frame: depth image is neither 16-bit nor float");
    }
  }
  s.added_t = frame.timestamp;
  Impl::PendingFrame p{frame, {}};
  if (s.front_end_queue) {
    p.front_end = s.front_end_queue->submit<Impl::FrontEnd>([&s, frame] { return s.frontEnd(frame); });
  }
  s.pending.push_back(std::move(p));
  s.drain(false);
}

void Estimator::finish() {
  Impl& s = *impl_;
  s.drain(true);
  s.waitForMapper();
  if (!s.keyframes.empty() && s.opt.mode != Mode::kWheel) {
    s.applyLabels(true);
    s.localBundleAdjustment();  // the last keyframes get their full share of refinement
  }
}

std::vector<PoseEstimate> Estimator::trajectory() const {
  std::lock_guard<std::mutex> lock(impl_->map_mutex);
  std::vector<PoseEstimate> out;
  out.reserve(impl_->frames.size());
  for (const FrameRecord& f : impl_->frames) out.push_back({f.t, impl_->kfPose(f.ref_kf) * f.T_kf_b, f.visual});
  return out;
}

Report Estimator::report() const {
  std::lock_guard<std::mutex> lock(impl_->map_mutex);
  Report r = impl_->counters;
  r.frames = impl_->frames.size();
  r.keyframes = impl_->next_kf;
  r.map_keyframes = impl_->keyframes.size();
  r.map_points = impl_->points.size();
  r.retired_keyframes = impl_->final_pose.size();
  r.slip_frames = impl_->slip_frames;
  r.wheel_edge_outliers = impl_->wheel_outliers;
  if (const std::uint64_t failed = impl_->async ? impl_->async->stats().failed : 0) {
    r.segmentation_failures += failed;
    if (r.segmentation_error.empty()) r.segmentation_error = "a keyframe: " + impl_->async->lastError();
  }
  {
    std::lock_guard<std::mutex> olock(impl_->odometry_mutex);
    r.wheel_calibration = impl_->calibration.c;
  }
  r.timings = impl_->timings.stats();
  return r;
}

void Estimator::setFrameCallback(std::function<void(const PoseEstimate&)> callback) {
  impl_->callback = std::move(callback);
}

}  // namespace rvwo::estimator
