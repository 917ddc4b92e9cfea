// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "rvwo/orbslam3/wheel_input.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "rvwo/ceres/barron_loss.h"
#include "rvwo/ceres/costs.h"
#include "rvwo/ceres/se2_manifold.h"
#include "rvwo/edges/camera.h"
#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/kernels/reliability.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/semantics/label_lookup.h"
#include "rvwo/semantics/onnx_segmenter.h"
#include "rvwo/settings/settings.h"
#include "rvwo/tracking/planar_pose.h"
#include "rvwo/tracking/wheel_checks.h"
#include "rvwo/tracking/window.h"

namespace rvwo::orbslam3 {
namespace {

// A point whose P_s (eq. 4) is below this counts as vision's evidence against the wheels (the
// estimator's Estimator.TrustedMaxPs default).
constexpr double kTrustedMaxPs = 0.1;

SE2 planar(const Eigen::Isometry3d& T) {
  return SE2(T.translation().x(), T.translation().y(), std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
}

}  // namespace

struct WheelInput::Impl {
  Impl(const WheelInputParams& p, const WheelNoise& noise, const ReliabilityParams& r, SemanticPriors sp)
      : params(p), odometry(noise, planar(p.T_b_o)), reliability(r), priors(std::move(sp)) {
    drive.radius_left = p.radius_left;
    drive.radius_right = p.radius_right;
    drive.track = p.track;
    drive.validate();
    noise.validate();
    if (!(p.calibration_period > 0)) throw std::invalid_argument("WheelInputParams: calibration_period must be > 0 s");
    if (p.spin_min_frames < 1) throw std::invalid_argument("WheelInputParams: spin_min_frames must be >= 1");
    calibration.counting = p.calibration_constant;
    if (!(p.mono_keyframe_travel > 0))
      throw std::invalid_argument("WheelInputParams: mono_keyframe_travel must be > 0 m");
    out_of_plane.sigma_z = p.sigma_z;
    out_of_plane.sigma_rollpitch = Eigen::Matrix2d::Identity() * p.sigma_rollpitch * p.sigma_rollpitch;
  }
  // Tracking calls everything but optimiseLocalMap, ORB-SLAM3's local mapping thread that: what
  // both read or write (the readings, the reliabilities, the slips) is guarded by this.
  mutable std::mutex mutex;
  WheelInputParams params;
  DiffDriveParams drive;
  WheelOdometry odometry;
  // The odometry's calibration, refined by each local map the wheels agree with (optimiseLocalMap)
  // and applied to every wheel delta (the suite's wheels: radii 1 % off each way, a turn-rate bias
  // of 0.9 deg/s at 0.3 m/s, which tight wheel edges between keyframes pressed onto the map).
  ceres_adapters::WheelCalibrationEstimate calibration;
  WheelDelta integrate(double t0, double t1) const { return odometry.integrate(t0, t1, calibration.c); }
  std::size_t wheel_frames = 0;
  std::atomic<std::size_t> local_maps_solved{0}, local_maps_calibrated{0};  // local mapping's thread
  int run = 0;  // frames on the wheels in a row, this one included
  bool keyframe = false;
  // m the wheels went since the last keyframe frameTracked asked for while on them, or since the
  // run's start: summed frame by frame, so that it never reaches past the readings kept (a minute).
  double travel = 0.0;
  bool blind = false;  // the frame tracked last was on the wheels with fewer than min_features
  // Mono: the map is in metres (monocularScale), the wheels' scale. Read by local mapping too.
  std::atomic<bool> metric{false};
  double monocularScale(double t0, double t1, const Eigen::Isometry3d& T_c0_w, const Eigen::Isometry3d& T_c1_w) const;
  std::vector<std::pair<double, double>> intervals;
  // ---- pose optimisation
  ReliabilityManager reliability;  // per map point id: eq. 6 from its latest whitened error
  OutOfPlaneNoise out_of_plane;
  std::optional<PinholeCamera> camera;  // made with the first problem (ORB-SLAM3's intrinsics)
  std::optional<Se2XyzMonoEdge> mono;
  std::optional<Se2XyzStereoEdge> stereo;
  // The last solve was a slip: the previous frame's last, or this frame's first (ORB-SLAM3 solves
  // a frame up to twice, motion model then local map): the second solve refines the same frame,
  // and goes on with a slip its first one found. (Judging it against the previous frame only
  // measured no better: stereo slip ATE 0.0123 and 0.0137 m, against 0.0113 and 0.0169 m this way.)
  bool slipping = false;
  std::size_t slip_frames = 0;
  // Where the wheels were overruled, (from, to] on the camera's clock: a wheel edge of the local
  // map across one gets a Huber kernel (it measured motion that did not happen). A creep counts
  // from the start of the stretch that showed it. Kept, as the chain of keyframes is (16 bytes a
  // slip, consecutive frames merged).
  std::deque<std::pair<double, double>> slipped;
  void markSlip(double from, double to) {
    if (!slipped.empty() && from <= slipped.back().second) {
      slipped.back().first = std::min(slipped.back().first, from);
      slipped.back().second = std::max(slipped.back().second, to);
    } else {
      slipped.emplace_back(from, to);
    }
  }
  bool slipBetween(double ti, double tj) const {
    for (const auto& [from, to] : slipped)
      if (from < tj && ti < to) return true;
    return false;
  }
  // Of those, the frames where the robot about stood while the wheels went on (slipIsSpin), once
  // each however often a frame was solved; kept as the slips are (8 bytes a frame).
  std::deque<double> spins;
  bool spinBetween(double ti, double tj) const {
    int n = 0;
    for (auto it = std::upper_bound(spins.begin(), spins.end(), ti); it != spins.end() && *it <= tj; ++it) ++n;
    return n >= params.spin_min_frames;
  }
  bool covers(double ti, double tj) const {
    return !odometry.empty() && ti <= tj && odometry.firstTime() <= ti && tj <= odometry.lastTime();
  }
  // The wheels between keyframes, kept for the whole run: chain[t] is the delta from the keyframe
  // before t in time (any map's, culled or not) to keyframe t, none where the readings did not
  // cover that stretch. Taken where a keyframe is first seen in a problem (its local map, a few
  // seconds after tracking made it), it outlives the readings (20 to 60 s), so that the global
  // BA and the essential graph after a loop have wheel edges over the whole map, not only its
  // last 20 s. About 300 bytes a keyframe. Under the mutex.
  std::map<double, std::optional<WheelDelta>> chain;
  void remember(const std::vector<double>& t) {
    for (const double tk : t) {
      if (chain.count(tk) || !covers(tk, tk)) continue;
      const auto next = chain.upper_bound(tk);
      std::optional<WheelDelta> from_before;
      if (next != chain.begin()) {
        const double before = std::prev(next)->first;
        if (covers(before, tk)) from_before = integrate(before, tk);
      }
      // The keyframe after it was seen first (its local map came before this one's): its stretch
      // now starts here. Readings cover it: they reach from tk to the last frame.
      if (next != chain.end()) next->second = integrate(tk, next->first);
      chain.emplace(tk, from_before);
    }
  }
  // The wheels from keyframe ta to keyframe tb through the chain, at the current calibration.
  std::optional<WheelDelta> chained(double ta, double tb) const {
    auto it = chain.find(ta);
    const auto end = chain.find(tb);
    if (it == chain.end() || end == chain.end() || !(tb > ta)) return std::nullopt;
    std::optional<WheelDelta> sum;
    while (it != end) {
      ++it;
      if (!it->second) return std::nullopt;
      const WheelDelta d = it->second->recalibrated(calibration.c);
      sum = sum ? compose(*sum, d) : d;
    }
    return sum;
  }

  // Wheel edges between keyframes consecutive in time (eq. 14), keyframe k at t[k]: one end at
  // least free, at most max_wheel_span apart, from the readings kept or else the chain. Under
  // the mutex.
  struct Span {
    std::size_t a, b;
    WheelDelta delta;
    bool slipped;
    bool spin;  // across spin_min_frames spin frames or more (stereo, RGB-D): the local map's second half only
  };
  std::vector<Span> wheelSpans(const std::vector<double>& t, const std::vector<char>& fixed) {
    remember(t);
    std::vector<std::size_t> order(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return t[a] < t[b]; });
    std::vector<Span> spans;
    for (std::size_t k = 0; k + 1 < order.size(); ++k) {
      const std::size_t a = order[k], b = order[k + 1];
      if ((fixed[a] && fixed[b]) || !(t[b] > t[a]) || t[b] - t[a] > params.max_wheel_span) continue;
      std::optional<WheelDelta> delta = covers(t[a], t[b]) ? integrate(t[a], t[b]) : chained(t[a], t[b]);
      if (delta)
        spans.push_back({a, b, *delta, slipBetween(t[a], t[b]), params.map_from_depth && spinBetween(t[a], t[b])});
    }
    return spans;
  }
  WindowProblem windowProblem(const LocalMapProblem& pb, std::vector<Span>* spans);
  WindowOptions windowOptions(const ceres_adapters::WheelCalibrationEstimate& cal, const bool* stop) const;
  void learnCalibration(const WindowProblem& w, const std::vector<Span>& spans, const WindowSolution& sol);

  // The last frame optimisePose placed, and the last one of those vision went on to track: after
  // a stretch on the wheels alone the wheel edge starts there, so that it carries the stretch's
  // whole uncertainty. (Tied to the previous frame, itself the wheels' guess, it held the frame
  // to the stretch's drift: vision back after the 2 s blackout at 45 s found the old map 2.3 deg
  // off the wheels and lost to them; the ATE doubled.)
  struct Placed {
    double t = 0.0;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    bool set = false;
    bool slip = false;  // vision alone overruled the wheels
  } solved, anchor;

  // Vision alone's recent poses (each frame's last solve without the wheel edge, where it placed
  // the frame), over the stretch wheelsCreep judges: kCreepStretch, long enough for a creep of a
  // few millimetres a frame to add up beyond what it allows (8 mm a frame: 3 to 6 frames), short
  // enough for the map's errors and the wheels' calibration to stay within it (wheelsCreep).
  static constexpr double kCreepStretch = 0.5;  // s
  struct Seen {
    double t;
    Eigen::Vector3d x;
    Eigen::Matrix3d information;
  };
  std::deque<Seen> vision_track;

  // ---- labels
  SemanticPriors priors;
  std::unique_ptr<AsyncSegmenter> segmenter;
  std::uint64_t keyframes_sent = 0;
  std::map<std::uint64_t, std::vector<KeyFrameFeature>> waiting;  // keyframe -> its features
  std::size_t segmented = 0;

  // Labels that have come: semantic observations of the map points the keyframes' keypoints see
  // (eqs. 4, 5). Keyframes dropped or failed are done with (their points keep what they had).
  // deadline: how long it may wait for those still to come (none: it takes what is there).
  void applyLabels(std::optional<std::chrono::steady_clock::time_point> deadline = std::nullopt) {
    for (auto it = waiting.begin(); it != waiting.end();) {
      std::optional<Segmentation> seg =
          deadline ? segmenter->waitFor(it->first, std::chrono::duration_cast<std::chrono::milliseconds>(
                                                       *deadline - std::chrono::steady_clock::now()))
                   : segmenter->take(it->first);
      if (!seg && segmenter->pending(it->first)) {
        ++it;
        continue;
      }
      if (seg) {
        ++segmented;
        const LabelLookup lookup(*seg, priors.dynamicLabels(), params.label_dilation_px);
        for (const KeyFrameFeature& f : it->second) {
          const int label = lookup.labelAt(cv::Point2f(f.u, f.v));
          if (label >= 0) reliability.observe(f.id, priors.prior(label), std::nullopt);
        }
      }
      it = waiting.erase(it);
    }
  }

  void makeEdges(const PoseProblem& p) {
    if (camera && camera->fx() == p.fx && camera->fy() == p.fy && camera->cx() == p.cx && camera->cy() == p.cy &&
        stereo_bf == p.bf)
      return;
    mono.reset();
    stereo.reset();
    camera.emplace(p.fx, p.fy, p.cx, p.cy);
    mono.emplace(*camera, params.T_b_c);
    if (p.bf > 0) stereo.emplace(*camera, params.T_b_c, p.bf);  // none for mono (bf 0)
    stereo_bf = p.bf;
  }
  double stereo_bf = 0.0;

  // The robot's planar pose x_w_b (w: the body frame under the map's origin camera, T_w_c0 = T_b_c)
  // of a camera pose in ORB-SLAM3's world (its origin camera's frame). Out of the plane parts
  // (height, roll, pitch: local BA moves keyframes in 6 DoF) are dropped.
  Eigen::Vector3d planarOf(const Eigen::Isometry3d& T_c_w) const {
    const Eigen::Isometry3d& T_b_c = params.T_b_c;
    return planar(T_b_c * T_c_w.inverse() * T_b_c.inverse()).vector();
  }
  Eigen::Isometry3d cameraOf(const Eigen::Vector3d& x) const {
    const Eigen::Isometry3d& T_b_c = params.T_b_c;
    return T_b_c.inverse() * SE2::fromVector(x).isometry3().inverse() * T_b_c;
  }
};

WheelInput::WheelInput() = default;
WheelInput::~WheelInput() = default;

void WheelInput::configure(const WheelInputParams& p) {
  impl_ = std::make_unique<Impl>(p, WheelNoise(), ReliabilityParams(), SemanticPriors::builtin("voc21"));
}

void WheelInput::configure(const std::string& settings_path) {
  const Settings s = Settings::load(settings_path);
  if (!s.has("Camera.T_b_c") && s.keysWithPrefix("Odometry.").empty()) {
    impl_.reset();
    return;
  }
  WheelInputParams p;
  p.T_b_c = readIsometry(s, "Camera.T_b_c", true);
  p.T_b_o = readIsometry(s, "Odometry.T_b_o", false);
  const DiffDriveParams d = readDiffDrive(s);
  p.radius_left = d.radius_left;
  p.radius_right = d.radius_right;
  p.track = d.track;
  const std::string sensor = s.text("Sensor").value_or("stereo");
  p.map_from_depth = sensor != "mono";
  p.aligned_pyramid = s.number("ORBextractor.AlignedPyramid").value_or(1.0) != 0.0;
  p.planar = s.number("Tracking.Planar").value_or(1.0) != 0.0;
  const std::string kernel = s.text("Tracking.Kernel").value_or("adaptive");
  if (kernel != "adaptive" && kernel != "huber")
    throw std::invalid_argument(settings_path + ": Tracking.Kernel is '" + kernel + "', not adaptive or huber");
  p.huber = kernel == "huber";
  p.barron_scale = s.number("Tracking.BarronScale").value_or(p.barron_scale);
  p.sigma_z = s.number("Tracking.SigmaZ").value_or(p.sigma_z);
  p.sigma_rollpitch = s.number("Tracking.SigmaRollPitch").value_or(p.sigma_rollpitch);
  p.slip_check = s.number("Tracking.SlipCheck").value_or(1.0) != 0.0;
  p.wheel_gate = s.number("Tracking.WheelGate").value_or(1.0) != 0.0;
  p.local_map = s.number("LocalMapping.Planar").value_or(1.0) != 0.0;
  p.max_wheel_span = s.number("LocalMapping.MaxWheelSpan").value_or(p.max_wheel_span);
  const double spin_frames = s.number("LocalMapping.SpinMinFrames").value_or(p.spin_min_frames);
  if (!(spin_frames >= 1 && spin_frames <= 1000 && spin_frames == std::floor(spin_frames)))
    throw std::invalid_argument(settings_path +
                                ": LocalMapping.SpinMinFrames must be a whole number of frames, 1 to 1000");
  p.spin_min_frames = static_cast<int>(spin_frames);
  p.init_min_travel = s.number("Initializer.MinTravel").value_or(p.init_min_travel);
  p.init_max_turn = s.number("Initializer.MaxTurnError").value_or(p.init_max_turn);
  p.init_max_path = s.number("Initializer.MaxPathError").value_or(p.init_max_path);
  if (!(p.init_min_travel > 0) || !(p.init_max_turn > 0) || !(p.init_max_path > 0))
    throw std::invalid_argument(settings_path + ": Initializer.MinTravel, .MaxTurnError and .MaxPathError must be > 0");
  p.essential_graph = s.number("LoopClosing.Planar").value_or(1.0) != 0.0;
  p.graph_sigma_xy = s.number("LoopClosing.SigmaXY").value_or(p.graph_sigma_xy);
  p.graph_sigma_yaw = s.number("LoopClosing.SigmaYaw").value_or(p.graph_sigma_yaw);
  if (!(p.graph_sigma_xy > 0) || !(p.graph_sigma_yaw > 0))
    throw std::invalid_argument(settings_path + ": LoopClosing.SigmaXY and .SigmaYaw must be > 0");
  p.calibrate = s.number("Odometry.Calibrate").value_or(1.0) != 0.0;
  p.calibration_constant = s.number("Odometry.CalibrationConstant").value_or(0.0) != 0.0;
  // Mono: vision has no scale of its own (the map's is the wheels'), so it cannot tell the wheels'.
  p.calibrate_distance = s.number("Odometry.CalibrateDistance").value_or(p.map_from_depth ? 1.0 : 0.0) != 0.0;
  if (!(p.max_wheel_span > 0)) throw std::invalid_argument(settings_path + ": LocalMapping.MaxWheelSpan must be > 0 s");
  const double dilation = s.number("Segmentation.LabelDilation").value_or(p.label_dilation_px);
  if (!(dilation >= 0 && dilation <= 100 && dilation == std::floor(dilation)))
    throw std::invalid_argument(settings_path +
                                ": Segmentation.LabelDilation must be a whole number of pixels, 0 to 100");
  p.label_dilation_px = static_cast<int>(dilation);
  if (!(p.barron_scale > 0) || !(p.sigma_z >= 0) || !(p.sigma_rollpitch >= 0))
    throw std::invalid_argument(settings_path +
                                ": Tracking.BarronScale must be > 0, Tracking.SigmaZ and .SigmaRollPitch >= 0");
  try {
    impl_ = std::make_unique<Impl>(p, readWheelNoise(s), readReliability(s), readSemanticPriors(s));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(settings_path + ": " + e.what());
  }
  // A network for the keyframes' labels, named in the settings (relative to the settings file).
  if (const auto model = s.file("Segmentation.Model")) {
    OnnxSegmenterOptions o;
    o.model_path = *model;
    o.class_names = impl_->priors.classes();
    try {
      setSegmenter(std::make_shared<OnnxSegmenter>(o));
    } catch (const std::exception& e) {
      impl_.reset();
      throw std::invalid_argument(settings_path + ": Segmentation.Model " + o.model_path + ": " + e.what());
    }
  }
}

bool WheelInput::active() const { return impl_ != nullptr; }

bool WheelInput::alignedPyramid() const { return impl_ && impl_->params.aligned_pyramid; }

void WheelInput::add(const std::vector<WheelReading>& readings) {
  if (!impl_) {
    if (readings.empty()) return;
    throw std::invalid_argument(
        "wheel readings given, but the settings have no Camera.T_b_c (RVWO's wheel input is off)");
  }
  std::lock_guard<std::mutex> lock(impl_->mutex);
  for (const WheelReading& r : readings) {
    switch (r.kind) {
      case WheelReading::kWheelAngles:
        impl_->odometry.addWheelAngles(r.t, r.a, r.b, impl_->drive);
        break;
      case WheelReading::kWheelSpeeds:
        impl_->odometry.addWheelSpeeds(r.t, r.a, r.b, impl_->drive);
        break;
      case WheelReading::kPose:
        impl_->odometry.addPose(r.t, SE2(r.a, r.b, r.c));
        break;
      default:
        throw std::invalid_argument("wheel reading of unknown kind");
    }
  }
}

bool WheelInput::covers(double ti, double tj) const {
  if (!impl_) return false;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->covers(ti, tj);
}

Eigen::Isometry3d WheelInput::predict(const Eigen::Isometry3d& T_ci_w, double ti, double tj) const {
  if (!impl_) throw std::out_of_range("wheel readings do not cover the frames' times");
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (!impl_->covers(ti, tj)) throw std::out_of_range("wheel readings do not cover the frames' times");
  const Eigen::Isometry3d T_bi_bj = impl_->integrate(ti, tj).pose().isometry3();
  const Eigen::Isometry3d& T_b_c = impl_->params.T_b_c;
  return T_b_c.inverse() * T_bi_bj.inverse() * T_b_c * T_ci_w;
}

void WheelInput::frameTracked(double t, bool visual, int features) {
  if (!impl_) return;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const bool solved = m.solved.set && m.solved.t == t;
  if (visual && solved) m.anchor = m.solved;
  // A frame is a slip when its last solve was one (counted once, however often it was solved).
  m.slip_frames += solved && m.solved.slip;
  // Predictions start at the last frame, wheel edges at the last visual one, the local map's at
  // keyframes up to max_wheel_span apart, among the last kKeepForLocalMap seconds' (older ones
  // are held fixed there; after a loop their wheel edges come from the chain of keyframes).
  // Memory stays bounded: at most a minute of readings.
  constexpr double kKeepForLocalMap = 20.0;  // s
  const double keep = m.anchor.set ? std::min(t - kKeepForLocalMap, m.anchor.t - 1.0) : t - kKeepForLocalMap;
  m.odometry.dropBefore(std::max(t - 60.0, keep));
  m.blind = !visual && features < m.params.min_features;
  if (visual) {
    m.run = 0;
    m.keyframe = false;
    return;
  }
  ++m.wheel_frames;
  if (m.run++ == 0) {
    m.intervals.emplace_back(t, t);
    m.travel = 0.0;
  } else {
    const double t_previous = m.intervals.back().second;
    if (!m.params.map_from_depth && m.covers(t_previous, t)) m.travel += m.integrate(t_previous, t).distance;
    m.intervals.back().second = t;
  }
  // A frame held on the wheels past a momentary failure, with features again: a keyframe now
  // and then gives tracking new map points at the wheel pose. Stereo and RGB-D from its depth,
  // every keyframe_every frames; mono once its map is in metres, triangulated against the
  // keyframes before it in time (triangulatesInTime), each mono_keyframe_travel of the wheels
  // after the last for the parallax ORB-SLAM3 asks of a new point (1.15 deg).
  const bool seeing = features >= m.params.min_features && m.run >= 2;
  if (m.params.map_from_depth) {
    m.keyframe = seeing && (m.run - 2) % m.params.keyframe_every == 0;
  } else {
    m.keyframe = seeing && m.metric && m.travel >= m.params.mono_keyframe_travel;
  }
  if (m.keyframe) m.travel = 0.0;
}

bool WheelInput::keyFrameNeeded() const { return impl_ && impl_->keyframe; }

bool WheelInput::triangulatesInTime() const { return impl_ && !impl_->params.map_from_depth && impl_->metric; }

bool WheelInput::keyFrameWanted(bool orbslam3_needs) const {
  if (!impl_) return orbslam3_needs;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return (orbslam3_needs && !impl_->blind) || impl_->keyframe;
}

std::size_t WheelInput::wheelOnlyFrames() const { return impl_ ? impl_->wheel_frames : 0; }

std::vector<std::pair<double, double>> WheelInput::wheelOnlyIntervals() const {
  return impl_ ? impl_->intervals : std::vector<std::pair<double, double>>{};
}

double WheelInput::monocularScale(double t0, double t1, const Eigen::Isometry3d& T_c0_w,
                                  const Eigen::Isometry3d& T_c1_w) {
  if (!impl_ || impl_->params.map_from_depth) return -1.0;
  const double scale = impl_->monocularScale(t0, t1, T_c0_w, T_c1_w);
  impl_->metric = scale > 0;
  return scale;
}

double WheelInput::Impl::monocularScale(double t0, double t1, const Eigen::Isometry3d& T_c0_w,
                                        const Eigen::Isometry3d& T_c1_w) const {
  const Impl& m = *this;
  WheelDelta d;
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    if (!m.covers(t0, t1)) return -1.0;
    d = m.integrate(t0, t1);
  }
  if (d.dp.norm() < m.params.init_min_travel) return 0.0;  // a rotation, or too short a baseline
  // The body's motion the map implies, its translation affine in the unknown scale s:
  //   T_b0_b1 = T_b_c T_c0_c1(s) T_c_b,  p_b0_b1(s) = s R_b_c t_c0_c1 + t_b_c - R_b0_b1 t_b_c
  const Eigen::Isometry3d& T_b_c = m.params.T_b_c;
  const Eigen::Isometry3d T_c0_c1 = T_c0_w * T_c1_w.inverse();
  const Eigen::Matrix3d R_b0_b1 = T_b_c.linear() * T_c0_c1.linear() * T_b_c.linear().transpose();
  // Its turn against the wheels' (a tilt counts: the robot stays on its floor).
  const double turn =
      Eigen::AngleAxisd(Eigen::AngleAxisd(d.dphi, Eigen::Vector3d::UnitZ()).toRotationMatrix().transpose() * R_b0_b1)
          .angle();
  if (turn > m.params.init_max_turn + 3.0 * std::sqrt(d.covariance(2, 2))) return 0.0;
  const Eigen::Vector2d a = (T_b_c.linear() * T_c0_c1.translation()).head<2>();
  const Eigen::Vector2d c = (T_b_c.translation() - R_b0_b1 * T_b_c.translation()).head<2>();
  if (a.squaredNorm() < 1e-12) return 0.0;  // no translation at all
  const double scale = a.dot(d.dp - c) / a.squaredNorm();
  // Travel in the wheels' direction, as far as theirs give or take their noise.
  const double off = (scale * a + c - d.dp).norm();
  const double sigma_p = std::sqrt(d.covariance.topLeftCorner<2, 2>().trace());
  if (!(scale > 0) || off > m.params.init_max_path * d.dp.norm() + 3.0 * sigma_p) return 0.0;
  return scale;
}

bool WheelInput::optimisesPoses() const {
  return impl_ && impl_->params.planar && (impl_->params.map_from_depth || impl_->metric);
}

bool WheelInput::optimisePose(const PoseProblem& pb, PoseSolution* out) {
  if (!optimisesPoses() || pb.matches.size() < 3) return false;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  if (m.segmenter) m.applyLabels();
  m.makeEdges(pb);
  const std::size_t n = pb.matches.size();
  // Trusted points: no label has called them dynamic and, with a segmenter, a label has reached
  // them (the estimator's rule). With the adaptive kernel only they place the pose and count as
  // vision's evidence against the wheels; the others are judged against the gate. A keyframe's
  // new points are the closest features, often a walker's: placing frames before their labels
  // came, they turned the robot 10 to 19 deg it did not turn (RGB-D dynamic, 0 to 6 s), and
  // vision alone took 30 frames there for slips.
  // Mono excepted: its points are triangulated after the keyframes that see them were segmented,
  // so labels reach them only through later keyframes; waiting for those, tracking starved (the
  // mono static scenario: on the wheels from 6 s to the end). There labels only reject.
  const bool need_label = m.segmenter && m.params.map_from_depth;
  std::vector<char> trusted(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::optional<LandmarkReliability> rel = m.reliability.get(pb.matches[k].id);
    trusted[k] = (!rel || rel->ps < kTrustedMaxPs) && (!need_label || (rel && rel->labelled > 0));
  }
  std::vector<PoseObservation> obs(n);
  for (std::size_t k = 0; k < n; ++k) {
    const PoseMatch& a = pb.matches[k];
    PoseObservation& o = obs[k];
    o.P_w = m.params.T_b_c * a.P_w;  // into the planar world
    o.z = Eigen::Vector3d(a.u, a.v, a.u_right);
    o.stereo = a.u_right >= 0;
    o.sigma_px = std::pow(pb.scale_factor, a.level);  // ORB-SLAM3's: 1 px at level 0
    o.alpha = m.params.huber ? 1.0 : m.reliability.alpha(a.id);
    o.usable = m.params.huber || trusted[k];
  }
  PlanarPoseOptions opt;
  opt.huber = m.params.huber;
  opt.barron_scale = m.params.barron_scale;
  opt.out_of_plane = m.out_of_plane;

  // The wheel edge from the previous frame (eq. 14), when the readings cover both frames.
  std::optional<WheelDelta> delta;
  std::optional<WheelEdge> edge;
  Eigen::Vector3d x_prev = Eigen::Vector3d::Zero();
  const bool from_anchor = m.run > 0 && m.anchor.set && m.covers(m.anchor.t, pb.t);
  if (from_anchor || (pb.has_previous && m.covers(pb.t_previous, pb.t))) {
    x_prev = from_anchor ? m.anchor.x : m.planarOf(pb.T_cp_w);
    delta = m.integrate(from_anchor ? m.anchor.t : pb.t_previous, pb.t);
    try {
      edge.emplace(*delta);
    } catch (const std::invalid_argument&) {  // degenerate covariance: vision alone
      delta.reset();
    }
  }
  Eigen::Vector3d x = m.planarOf(pb.T_c_w);
  PlanarPoseResult r = optimisePlanarPose(*m.mono, m.stereo ? &*m.stereo : nullptr, obs,
                                          WheelPrior{edge ? &*edge : nullptr, x_prev}, opt, &x);

  // Slip: the wheels claimed motion the robot did not make, so every static point disagrees with
  // them and vision alone, started where the robot was, explains clearly more of the trusted
  // points (the estimator's test). Among walkers the wheels side with the static points and keep
  // the pose (looksLikeSlip).
  bool slip = false;
  double slip_from = from_anchor ? m.anchor.t : pb.t_previous;
  const bool strained = edge && wheelEdgeStrained(*edge, x_prev, x);
  if (edge && m.params.slip_check) {
    // Vision alone every frame (0.5 to 2 ms for 100 to 300 matches, rvwo_bench_tracking; ORB-SLAM3's
    // TrackFrame averaged 26 to 28 ms on the stereo slip scenario with it): its own track is what
    // shows wheels that creep.
    Eigen::Vector3d x_vision = x_prev;
    PlanarPoseResult rv =
        optimisePlanarPose(*m.mono, m.stereo ? &*m.stereo : nullptr, obs, WheelPrior{}, opt, &x_vision);
    // ORB-SLAM3's bar for a tracked frame (30 inliers), twice over, for vision to overrule the wheels.
    constexpr int kMinVision = 60;
    const auto countTrusted = [&](const std::vector<char>& inlier) {
      int count = 0;
      for (std::size_t k = 0; k < n; ++k) count += inlier[k] && trusted[k];
      return count;
    };
    const int candidates = static_cast<int>(std::count(trusted.begin(), trusted.end(), 1));
    const int vision_inliers = countTrusted(rv.inlier);
    const bool placed = vision_inliers >= kMinVision && vision_inliers >= 0.85 * static_cast<double>(candidates);
    auto& track = m.vision_track;
    if (!track.empty() && track.back().t == pb.t) track.pop_back();  // the frame solved again
    while (!track.empty() && track.front().t < pb.t - Impl::kCreepStretch) track.pop_front();
    bool creeping = false;
    if (placed && !track.empty() && m.covers(track.front().t, pb.t)) {
      const WheelDelta stretch = m.integrate(track.front().t, pb.t);
      creeping = wheelsCreep(stretch, track.front().x, track.front().information, x_vision, rv.information);
      if (creeping) slip_from = std::min(slip_from, track.front().t);
    }
    if (placed) track.push_back({pb.t, x_vision, rv.information});
    SlipEvidence e;
    e.wheels = &*delta;
    e.T_b0_b1_fused = SE2::fromVector(x_prev).inverse() * SE2::fromVector(x);
    e.T_b0_b1_vision = SE2::fromVector(x_prev).inverse() * SE2::fromVector(x_vision);
    e.fused_inliers = countTrusted(r.inlier);
    e.vision_inliers = vision_inliers;
    e.candidates = candidates;
    e.strained = strained;
    e.creeping = creeping;
    e.was_slipping = m.slipping;
    e.min_to_start = e.min_to_go_on = kMinVision;
    if (decideSlip(e)) {
      slip = true;
      x = x_vision;
      r = std::move(rv);
      m.markSlip(slip_from, pb.t);
      if (slipIsSpin(*delta, e.T_b0_b1_vision) && (m.spins.empty() || m.spins.back() < pb.t)) m.spins.push_back(pb.t);
    }
  }
  // The wheel gate (rvwo::solveFromTheWheels; adaptive kernel, stereo and RGB-D), the estimator's:
  // walkers no label marks drag the fused pose off the wheels a little every frame. Not from the
  // anchor: vision back after frames on the wheels corrects their drift.
  if (strained && !slip && !from_anchor && m.params.wheel_gate && !m.params.huber && m.params.map_from_depth) {
    const Eigen::Vector3d x_predicted = (SE2::fromVector(x_prev) * delta->pose()).vector();
    constexpr int kMinPlace = 30;  // ORB-SLAM3's bar for a tracked frame
    PlanarPoseResult gated;
    if (solveFromTheWheels(*m.mono, m.stereo ? &*m.stereo : nullptr, obs, WheelPrior{&*edge, x_prev}, opt, x_predicted,
                           trusted, kMinPlace, &x, &gated)) {
      r = std::move(gated);
    }
  }
  m.slipping = slip;
  m.solved = {pb.t, x, true, slip};
  // Eq. 6: every match's latest whitened error (outliers included: that is the point).
  if (!m.params.huber) {
    for (std::size_t k = 0; k < n; ++k) m.reliability.observe(pb.matches[k].id, std::nullopt, r.error[k]);
  }
  out->T_c_w = m.cameraOf(x);
  out->outlier.resize(n);
  for (std::size_t k = 0; k < n; ++k) out->outlier[k] = !r.inlier[k];
  out->inliers = r.inliers;
  out->slip = slip;
  return true;
}

std::size_t WheelInput::slipFrames() const { return impl_ ? impl_->slip_frames : 0; }
std::size_t WheelInput::localMapsSolved() const { return impl_ ? impl_->local_maps_solved.load() : 0; }
std::size_t WheelInput::localMapsCalibrated() const { return impl_ ? impl_->local_maps_calibrated.load() : 0; }

Eigen::Vector3d WheelInput::calibration() const {
  if (!impl_) return Eigen::Vector3d::Zero();
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->calibration.c;
}

bool WheelInput::optimisesLocalMaps() const { return optimisesPoses() && impl_->params.local_map; }

// The problem on the plane: keyframes as robot poses x_w_b (out of the plane parts dropped, as
// tracking drops them), points in the planar world (T_w_c0 = T_b_c), each point's shape (eq. 7),
// and the wheels between keyframes (ORB-SLAM3's local window is the covisible keyframes: mostly
// the last ones, whose wheel edges chain them to the fixed ones before). Locks the mutex.
WindowProblem WheelInput::Impl::windowProblem(const LocalMapProblem& pb, std::vector<Span>* spans) {
  WindowProblem w;
  const std::size_t nk = pb.keyframes.size();
  std::vector<double> t(nk);
  std::vector<char> fixed(nk);
  for (std::size_t k = 0; k < nk; ++k) {
    const MapKeyFrame& kf = pb.keyframes[k];
    w.keyframes.push_back({planarOf(kf.T_c_w), kf.t, kf.fixed});
    t[k] = kf.t;
    fixed[k] = kf.fixed;
  }
  const bool has_stereo = pb.keyframes.front().bf > 0;
  for (const MapObservation& o : pb.observations) {
    w.observations.push_back({o.keyframe, o.point, Eigen::Vector3d(o.u, o.v, o.u_right), o.u_right >= 0 && has_stereo,
                              std::pow(pb.scale_factor, o.level)});
  }
  std::lock_guard<std::mutex> lock(mutex);
  for (const MapPointEstimate& p : pb.points)
    w.points.push_back({params.T_b_c * p.P_w, params.huber ? 1.0 : reliability.alpha(p.id)});
  w.calibration = calibration;
  *spans = wheelSpans(t, fixed);
  for (const Span& sp : *spans)
    w.wheels.push_back({static_cast<int>(sp.a), static_cast<int>(sp.b), sp.delta, sp.slipped, sp.spin});
  return w;
}

// ORB-SLAM3's contract: outliers judged but not dropped between the rounds (it erases them
// afterwards), nothing solved unless a fixed keyframe holds the window, the abort flag obeyed.
WindowOptions WheelInput::Impl::windowOptions(const ceres_adapters::WheelCalibrationEstimate& cal,
                                              const bool* stop) const {
  WindowOptions o;
  o.huber = params.huber;
  o.barron_scale = params.barron_scale;
  o.out_of_plane = out_of_plane;
  o.min_views = 1;
  o.outliers_leave = false;
  o.drop_slipping_wheel_edges = false;
  o.slipped_wheel_chi2 = kChi2WheelOutlier;
  o.calibrate = params.calibrate;
  o.hold_distance_scale = !params.calibrate_distance;
  o.calibration_sigma = params.calibration_sigma;
  o.calibration_step = cal.counting ? params.calibration_drift : params.calibration_step;
  o.calibration_period = params.calibration_period;
  o.needs_a_fixed_keyframe = true;
  o.stop = stop;
  return o;
}

bool WheelInput::optimiseLocalMap(const LocalMapProblem& pb, LocalMapSolution* out, const bool* stop) {
  if (!optimisesLocalMaps()) return false;
  Impl& m = *impl_;
  const std::size_t nk = pb.keyframes.size(), np = pb.points.size();
  out->T_c_w.resize(nk);
  out->P_w = std::vector<Eigen::Vector3d>(np);
  out->placed.assign(nk, 0);
  out->solved.assign(np, 0);
  out->outlier.assign(pb.observations.size(), 0);
  out->wheel_edges = 0;
  out->calibrated = false;
  for (std::size_t k = 0; k < nk; ++k) out->T_c_w[k] = pb.keyframes[k].T_c_w;
  for (std::size_t i = 0; i < np; ++i) out->P_w[i] = pb.points[i].P_w;
  if (nk == 0) return true;

  std::vector<Impl::Span> spans;
  const WindowProblem w = m.windowProblem(pb, &spans);
  const MapKeyFrame& k0 = pb.keyframes.front();
  const PinholeCamera camera(k0.fx, k0.fy, k0.cx, k0.cy);
  const Se2XyzMonoEdge mono(camera, m.params.T_b_c);
  std::optional<Se2XyzStereoEdge> stereo;  // none for mono (bf 0)
  if (k0.bf > 0) stereo.emplace(camera, m.params.T_b_c, k0.bf);
  const WindowSolution sol = solveWindow(mono, stereo ? &*stereo : nullptr, w, m.windowOptions(w.calibration, stop));
  if (sol.ran) ++m.local_maps_solved;
  out->wheel_edges = sol.wheel_edges;
  out->calibrated = sol.calibrated;
  if (sol.calibrated) {
    ++m.local_maps_calibrated;
    m.learnCalibration(w, spans, sol);
  }
  out->outlier.assign(sol.outlier.begin(), sol.outlier.end());
  const Eigen::Isometry3d T_c0_w = m.params.T_b_c.inverse();
  // What was not in the problem (no edge: a keyframe neither seeing nor reached by the wheels, a
  // rejected point) stays as given.
  for (std::size_t k = 0; k < nk; ++k)
    if (sol.placed[k]) {
      out->T_c_w[k] = m.cameraOf(sol.x_w_b[k]);
      out->placed[k] = 1;
    }
  for (std::size_t i = 0; i < np; ++i)
    if (sol.solved[i]) {
      out->P_w[i] = T_c0_w * sol.P_w[i];
      out->solved[i] = 1;
    }
  return true;
}

// The calibration a local map taught, with what it knew of it (counting: the priors' and the
// information of the calibrated wheel edges ending after the last local map that refined it).
void WheelInput::Impl::learnCalibration(const WindowProblem& w, const std::vector<Span>& spans,
                                        const WindowSolution& sol) {
  Eigen::Matrix3d known = sol.calibration_information;
  const ceres_adapters::WheelCalibrationEstimate& cal = w.calibration;
  double newest_t = -1e300;
  for (const WindowKeyFrame& k : w.keyframes) newest_t = std::max(newest_t, k.t);
  for (const Span& sp : spans) {
    if (sp.spin || sp.slipped || !params.calibrate || !cal.counting || w.keyframes[sp.b].t <= cal.t) continue;
    try {
      const WheelEdge edge(sp.delta);
      known += ceres_adapters::wheelCalibrationInformation(edge, sol.x_w_b[sp.a], sol.x_w_b[sp.b], sol.calibration);
    } catch (const std::invalid_argument&) {  // degenerate covariance: no edge
    }
  }
  std::lock_guard<std::mutex> lock(mutex);
  calibration.refined(sol.calibration, newest_t, known);
}

bool WheelInput::optimisesEssentialGraphs() const { return optimisesLocalMaps() && impl_->params.essential_graph; }

bool WheelInput::optimiseEssentialGraph(const EssentialGraph& g, EssentialGraphSolution* out) {
  if (!optimisesEssentialGraphs()) return false;
  Impl& m = *impl_;
  const std::size_t nk = g.keyframes.size();
  out->T_c_w.resize(nk);
  out->wheel_edges = 0;
  std::vector<Eigen::Vector3d> x(nk);
  std::vector<double> t(nk);
  std::vector<char> fixed(nk);
  for (std::size_t k = 0; k < nk; ++k) {
    out->T_c_w[k] = g.keyframes[k].T_c_w;
    x[k] = m.planarOf(g.keyframes[k].T_c_w);
    t[k] = g.keyframes[k].t;
    fixed[k] = g.keyframes[k].fixed;
  }
  std::vector<Impl::Span> spans;
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    spans = m.wheelSpans(t, fixed);
  }

  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  // Vision's relative poses on the plane, in eq. 14's form (the residual of any measured T_bi_bj).
  // ORB-SLAM3 weighs them all alike (identity information on sim(3)); with the wheel edges beside
  // them they need a covariance of their own: graph_sigma_*.
  const Eigen::Isometry3d& T_b_c = m.params.T_b_c;
  WheelDelta seen;
  const double s_xy = m.params.graph_sigma_xy, s_yaw = m.params.graph_sigma_yaw;
  seen.covariance = Eigen::Vector3d(s_xy * s_xy, s_xy * s_xy, s_yaw * s_yaw).asDiagonal();
  for (const GraphEdge& e : g.edges) {
    if (e.i == e.j || e.i < 0 || e.j < 0 || static_cast<std::size_t>(std::max(e.i, e.j)) >= nk) continue;
    const SE2 T_bi_bj = planar(T_b_c * e.T_cj_ci.inverse() * T_b_c.inverse());
    seen.dp = T_bi_bj.translation();
    seen.dphi = T_bi_bj.angle();
    problem.AddResidualBlock(new ceres_adapters::WheelCost(WheelEdge(seen)), nullptr, x[e.i].data(), x[e.j].data());
  }
  for (const Impl::Span& sp : spans) {
    try {
      const WheelEdge edge(sp.delta);
      // Across a slip tracking caught, Huber at the 99.9 % gate, as in the local map.
      problem.AddResidualBlock(new ceres_adapters::WheelCost(edge),
                               sp.slipped ? new ceres::HuberLoss(std::sqrt(kChi2WheelOutlier)) : nullptr,
                               x[sp.a].data(), x[sp.b].data());
      ++out->wheel_edges;
    } catch (const std::invalid_argument&) {  // degenerate covariance: no edge
    }
  }
  for (std::size_t k = 0; k < nk; ++k) {
    if (!problem.HasParameterBlock(x[k].data())) continue;
    problem.SetManifold(x[k].data(), new ceres_adapters::SE2Manifold);
    if (fixed[k]) problem.SetParameterBlockConstant(x[k].data());
  }
  if (problem.NumResidualBlocks() == 0) return true;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;  // hundreds of keyframes, a few edges each
  so.max_num_iterations = 20;                             // ORB-SLAM3's
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) return true;  // as given
  for (std::size_t k = 0; k < nk; ++k)
    if (!fixed[k] && problem.HasParameterBlock(x[k].data())) out->T_c_w[k] = m.cameraOf(x[k]);
  return true;
}

void WheelInput::setSegmenter(const std::shared_ptr<Segmenter>& segmenter) {
  if (!impl_) throw std::logic_error("WheelInput::setSegmenter: not configured (no RVWO keys in the settings)");
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->waiting.clear();
  // Two waiting at most (latest wins): a segmenter slower than keyframes skips some, never lags.
  impl_->segmenter = segmenter ? std::make_unique<AsyncSegmenter>(segmenter, 2) : nullptr;
}

bool WheelInput::segments() const { return impl_ && impl_->segmenter; }

void WheelInput::keyFrame(double t, const cv::Mat& image, const std::vector<KeyFrameFeature>& features) {
  if (!segments()) return;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const std::uint64_t id = m.keyframes_sent++;
  // A copy: ORB-SLAM3's image may share the caller's buffer, which the next frame may overwrite.
  if (m.segmenter->submit(image.clone(), FrameInfo{id, t})) m.waiting.emplace(id, features);
  m.applyLabels();
}

void WheelInput::waitForLabels(double timeout_s) {
  if (!segments()) return;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->applyLabels(std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(static_cast<long>(std::max(0.0, timeout_s) * 1000) + 1));
}

std::size_t WheelInput::segmentedKeyFrames() const { return impl_ ? impl_->segmented : 0; }

double WheelInput::alpha(unsigned long id) const {
  if (!impl_) return 1.0;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->reliability.alpha(id);
}

}  // namespace rvwo::orbslam3
