// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The estimator's public interface, its options' checks and its report, and the frames waiting for
// their odometry. The work is done by its roles: the front end (front_end.h), the map (map.h), the
// wheels (wheels.h), the tracker (tracker.h) and local mapping (mapper.h).
#include <cmath>
#include <deque>
#include <stdexcept>

#include "front_end.h"
#include "map.h"
#include "mapper.h"
#include "tracker.h"
#include "wheels.h"

namespace rvwo::estimator {

struct Estimator::Impl {
  Impl(const Rig& r, const EstimatorOptions& o, std::shared_ptr<Segmenter> segmenter)
      : ctx(r, o),
        wheels(ctx),
        map(ctx, Mapper::labelsLater(o, segmenter.get())),
        mapper(ctx, map, wheels, std::move(segmenter)),
        front_end(ctx),
        tracker(ctx, map, wheels, mapper, front_end) {
    // The front end runs one frame ahead of tracking in a thread of its own (not deterministic,
    // no images in wheel mode): while tracking matches and optimises frame k, frame k+1's
    // features are being extracted.
    if (!o.deterministic && o.mode != Mode::kWheel) front_end_queue = std::make_unique<TaskQueue>();
  }

  // A frame waits until the odometry has passed its time, then is tracked.
  void drain(bool all);

  Context ctx;
  Wheels wheels;
  Map map;
  Mapper mapper;
  FrontEnd front_end;
  Tracker tracker;

  // Frames waiting for the odometry to pass their time, with their front ends under way.
  struct PendingFrame {
    FrameInput in;
    std::future<FrameFeatures> features;  // not valid: made when tracked (deterministic, wheel mode)
  };
  std::deque<PendingFrame> pending;
  double added_t = -1e300;                     // last frame added
  std::unique_ptr<TaskQueue> front_end_queue;  // last: its thread stops first
};

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

void Estimator::Impl::drain(bool all) {
  // A frame waits until the odometry has passed its time (so its prediction has the readings
  // that straddle it), for at most a second of frames.
  // With a front end running ahead, a frame is also held until the next one has come, so that
  // the next one's features are made while this one is tracked (a frame's latency more).
  const std::size_t lookahead = front_end_queue ? 1 : 0;
  while (pending.size() > (all ? 0 : lookahead)) {
    const double t = pending.front().in.timestamp;
    bool ready = all || ctx.opt.mode == Mode::kVo || pending.size() > static_cast<std::size_t>(ctx.rig.fps) + 1 ||
                 wheels.reached(t);
    if (!ready) break;
    PendingFrame next = std::move(pending.front());
    pending.pop_front();
    const auto t0 = Clock::now();
    tracker.processFrame(next.in, std::move(next.features));
    ctx.timings.add("tracking", msSince(t0));  // the frame's whole turn, its waits included
  }
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
  impl_->wheels.addPose(t, T_odom_o);
  impl_->drain(false);
}

void Estimator::addWheelAngles(double t, double q_left, double q_right) {
  impl_->wheels.addAngles(t, q_left, q_right);
  impl_->drain(false);
}

void Estimator::addWheelSpeeds(double t, double w_left, double w_right) {
  impl_->wheels.addSpeeds(t, w_left, w_right);
  impl_->drain(false);
}

void Estimator::addFrame(const FrameInput& frame) {
  Impl& s = *impl_;
  const Rig& rig = s.ctx.rig;
  if (!std::isfinite(frame.timestamp) || frame.timestamp <= s.added_t)
    throw std::invalid_argument("frame at t = " + std::to_string(frame.timestamp) +
                                ": timestamp not after the previous frame's");
  auto checkImage = [&](const cv::Mat& m, const char* what) {
    if (m.empty()) throw std::invalid_argument(std::string("frame: no ") + what + " image");
    if (m.cols != rig.width || m.rows != rig.height)
      throw std::invalid_argument(std::string("frame: ") + what + " image is " + std::to_string(m.cols) + "x" +
                                  std::to_string(m.rows) + ", the settings say " + std::to_string(rig.width) + "x" +
                                  std::to_string(rig.height));
    if (m.depth() != CV_8U && std::string(what) != "depth")
      throw std::invalid_argument(std::string("frame: ") + what + " image is not 8-bit");
  };
  if (s.ctx.opt.mode != Mode::kWheel) {
    checkImage(frame.image, "camera");
    if (rig.sensor == Sensor::kStereo) checkImage(frame.right, "right");
    if (rig.sensor == Sensor::kRgbd) {
      checkImage(frame.depth, "depth");
      if (frame.depth.type() != CV_16U && frame.depth.type() != CV_32F)
        throw std::invalid_argument("frame: depth image is neither 16-bit nor float");
    }
  }
  s.added_t = frame.timestamp;
  Impl::PendingFrame p{frame, {}};
  if (s.front_end_queue) {
    p.features = s.front_end_queue->submit<FrameFeatures>([&s, frame] { return s.front_end(frame); });
  }
  s.pending.push_back(std::move(p));
  s.drain(false);
}

void Estimator::finish() {
  Impl& s = *impl_;
  s.drain(true);
  s.mapper.waitForIdle();
  if (!s.map.keyframes.empty() && s.ctx.opt.mode != Mode::kWheel) {
    s.mapper.applyLabels(true);
    s.mapper.localBundleAdjustment();  // the last keyframes get their full share of refinement
  }
}

std::vector<PoseEstimate> Estimator::trajectory() const {
  const Map& map = impl_->map;
  std::lock_guard<std::mutex> lock(map.mutex);
  std::vector<PoseEstimate> out;
  out.reserve(map.frames.size());
  for (const FrameRecord& f : map.frames) out.push_back({f.t, map.pose(f), f.visual});
  return out;
}

Report Estimator::report() const {
  const Map& map = impl_->map;
  std::lock_guard<std::mutex> lock(map.mutex);
  Report r = map.counters;
  r.frames = map.frames.size();
  r.keyframes = map.next_kf;
  r.map_keyframes = map.keyframes.size();
  r.map_points = map.points.size();
  r.retired_keyframes = map.final_pose.size();
  r.slip_frames = impl_->tracker.slipFrames();
  r.wheel_edge_outliers = impl_->mapper.wheelOutliers();
  const AsyncSegmenter* async = impl_->mapper.asyncSegmenter();
  if (const std::uint64_t failed = async ? async->stats().failed : 0) {
    r.segmentation_failures += failed;
    if (r.segmentation_error.empty()) r.segmentation_error = "a keyframe: " + async->lastError();
  }
  r.wheel_calibration = impl_->wheels.calibration().c;
  r.timings = impl_->ctx.timings.stats();
  return r;
}

void Estimator::setFrameCallback(std::function<void(const PoseEstimate&)> callback) {
  impl_->tracker.setCallback(std::move(callback));
}

}  // namespace rvwo::estimator
