// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "rvwo/orbslam3/wheel_input.h"

#include <opencv2/imgproc.hpp>

#include "wheel_input_impl.h"

namespace rvwo::orbslam3 {
namespace {

// The keyframes' network: Segmentation.Model (relative to the settings file), the one RVWO ships
// when it is unset, none when it is "none". Throws std::invalid_argument or what loading throws.
std::shared_ptr<Segmenter> keyFrameSegmenter(const Settings& s, const SemanticPriors& priors) {
  if (s.text("Segmentation.Model") == std::optional<std::string>("none")) return nullptr;
  OnnxSegmenterOptions o;
  o.class_names = priors.classes();
  if (const auto model = s.file("Segmentation.Model")) {
    o.model_path = *model;
  } else if (priors.name() == kShippedModelLabelSet) {
    o.model_path = shippedModelPath();
  } else {
    throw std::invalid_argument("unset, and the network RVWO ships speaks " + std::string(kShippedModelLabelSet) +
                                ", not the Semantics.LabelSet " + priors.name() +
                                ": name that label set's network, or \"none\"");
  }
  try {
    return std::make_shared<OnnxSegmenter>(o);
  } catch (const std::exception& e) {
    throw std::invalid_argument(o.model_path + ": " + e.what());
  }
}

}  // namespace

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
  p.wheels = s.text("Odometry.Input") != std::optional<std::string>("none");
  p.T_b_c = readIsometry(s, "Camera.T_b_c", p.wheels);
  p.T_b_o = readIsometry(s, "Odometry.T_b_o", false);
  if (p.wheels) {
    const DiffDriveParams d = readDiffDrive(s);
    p.radius_left = d.radius_left;
    p.radius_right = d.radius_right;
    p.track = d.track;
  }
  const std::string sensor = s.text("Sensor").value_or("stereo");
  p.map_from_depth = sensor != "mono";
  p.aligned_pyramid = s.number("ORBextractor.AlignedPyramid").value_or(1.0) != 0.0;
  p.planar = s.number("Tracking.Planar").value_or(1.0) != 0.0;
  const std::string kernel = s.text("Tracking.Kernel").value_or("adaptive");
  if (kernel != "adaptive" && kernel != "huber")
    throw std::invalid_argument(settings_path + ": Tracking.Kernel is '" + kernel + "', not adaptive or huber");
  p.huber = kernel == "huber";
  p.tracking = readTrackingOptions(s, p.tracking);
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
  p.label_dilation_px = readLabelDilation(s, p.label_dilation_px);
  if (!p.wheels) p.planar = p.local_map = p.essential_graph = p.calibrate = false;
  try {
    impl_ = std::make_unique<Impl>(p, readWheelNoise(s), readReliability(s), readSemanticPriors(s));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(settings_path + ": " + e.what());
  }
  try {
    if (auto segmenter = keyFrameSegmenter(s, impl_->priors)) setSegmenter(segmenter);
  } catch (const std::exception& e) {
    impl_.reset();
    throw std::invalid_argument(settings_path + ": Segmentation.Model: " + e.what());
  }
}

bool WheelInput::active() const { return impl_ != nullptr; }

bool WheelInput::alignedPyramid() const { return impl_ && impl_->params.aligned_pyramid; }

void WheelInput::add(const std::vector<WheelReading>& readings) {
  if (!impl_ || !impl_->params.wheels) {
    if (readings.empty()) return;
    throw std::invalid_argument(impl_ ? "wheel readings given, but the settings say Odometry.Input: \"none\""
                                      : "wheel readings given, but the settings have no Camera.T_b_c (RVWO's wheel "
                                        "input is off)");
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
  if (!impl_ || !impl_->params.wheels) return;
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
  if (!impl_ || !impl_->params.wheels || impl_->params.map_from_depth) return -1.0;
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
  return impl_ && (!impl_->params.wheels || (impl_->params.planar && (impl_->params.map_from_depth || impl_->metric)));
}

// Trusted points: no label has called them dynamic and, with a segmenter, a label has reached them
// (the estimator's rule). With the adaptive kernel only they place the pose and count as vision's
// evidence against the wheels; the others are judged against the gate. A keyframe's new points are
// the closest features, often a walker's: placing frames before their labels came, they turned the
// robot 10 to 19 deg it did not turn (RGB-D dynamic, 0 to 6 s), and vision alone took 30 frames
// there for slips. Mono excepted: its points are triangulated after the keyframes that see them
// were segmented, so labels reach them only through later keyframes; waiting for those, tracking
// starved (the mono static scenario: on the wheels from 6 s to the end). There labels only reject.
// (Under the mutex.)
std::vector<char> WheelInput::Impl::trustedOf(const PoseProblem& pb) const {
  const bool need_label = segmenter && params.map_from_depth;
  std::vector<char> trusted(pb.matches.size());
  for (std::size_t k = 0; k < pb.matches.size(); ++k) {
    const std::optional<LandmarkReliability> rel = reliability.get(pb.matches[k].id);
    trusted[k] = (!rel || rel->ps < params.tracking.trusted_max_ps) && (!need_label || (rel && rel->labelled > 0));
  }
  return trusted;
}

// The frame's matches as the pose solver takes them, in the planar world. (Under the mutex.)
std::vector<PoseObservation> WheelInput::Impl::poseObservations(const PoseProblem& pb,
                                                                const std::vector<char>& trusted) const {
  std::vector<PoseObservation> obs(pb.matches.size());
  for (std::size_t k = 0; k < obs.size(); ++k) {
    const PoseMatch& a = pb.matches[k];
    PoseObservation& o = obs[k];
    o.P_w = params.T_b_c * a.P_w;  // into the planar world
    o.z = Eigen::Vector3d(a.u, a.v, a.u_right);
    o.stereo = a.u_right >= 0;
    o.sigma_px = std::pow(pb.scale_factor, a.level);  // ORB-SLAM3's: 1 px at level 0
    o.alpha = params.huber ? 1.0 : reliability.alpha(a.id);
    o.usable = params.huber || trusted[k];
  }
  return obs;
}

bool WheelInput::Impl::spatialPose(const PoseProblem& pb, PoseSolution* out) {
  // Trusted points place the pose; with too few of them (a keyframe's new points wait for their
  // labels, and no wheels carry the frame meanwhile) every point the labels have not rejected
  // does, each under its kernel.
  std::vector<char> trusted = trustedOf(pb);
  if (std::count(trusted.begin(), trusted.end(), 1) < params.tracking.min_inliers) trusted.assign(trusted.size(), 1);
  // The matches as the planar solve takes them, but in ORB-SLAM3's own world (no body frame).
  std::vector<PoseObservation> obs = poseObservations(pb, trusted);
  for (std::size_t k = 0; k < obs.size(); ++k) obs[k].P_w = pb.matches[k].P_w;
  SpatialPoseOptions o;
  o.huber = params.huber;
  Eigen::Isometry3d T_c_w = pb.T_c_w;
  const SpatialPoseResult r = optimiseSpatialPose(PinholeCamera(pb.fx, pb.fy, pb.cx, pb.cy), pb.bf, obs, o, &T_c_w);
  if (!params.huber) {
    for (std::size_t k = 0; k < obs.size(); ++k) reliability.observe(pb.matches[k].id, std::nullopt, r.error[k]);
  }
  out->T_c_w = T_c_w;
  out->inliers = markFits(pb, r.error, out);
  out->slip = false;
  return true;
}

// ORB-SLAM3 keeps, counts and maps what fits the pose: every match within its gate that its
// labels have not rejected, whether or not it placed the pose (an untrusted one waits for its
// labels; marked an outlier it would be dropped, uncounted, and culled as never found).
int WheelInput::Impl::markFits(const PoseProblem& pb, const std::vector<double>& error, PoseSolution* out) const {
  const std::size_t n = pb.matches.size();
  out->outlier.resize(n);
  int fit = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const bool fits = error[k] * error[k] <= chi2Gate(pb.matches[k].u_right >= 0) &&
                      (params.huber || reliability.alpha(pb.matches[k].id) != -BarronKernel::kInfinity);
    out->outlier[k] = !fits;
    fit += fits;
  }
  return fit;
}

// The wheel edge from the previous frame (eq. 14), when the readings cover both frames; after a
// stretch on the wheels alone, from the anchor (the last frame vision went on to track).
WheelInput::Impl::WheelPriorOfFrame WheelInput::Impl::wheelPriorOf(const PoseProblem& pb) const {
  WheelPriorOfFrame w;
  w.from_anchor = run > 0 && anchor.set && covers(anchor.t, pb.t);
  w.t_prev = w.from_anchor ? anchor.t : pb.t_previous;
  if (w.from_anchor || (pb.has_previous && covers(pb.t_previous, pb.t))) {
    w.x_prev = w.from_anchor ? anchor.x : planarOf(pb.T_cp_w);
    w.delta = integrate(w.t_prev, pb.t);
  }
  return w;
}

// The frame as the arbiter takes it. The wheel gate is not tried from the anchor: vision back after
// frames on the wheels corrects their drift. (Under the mutex.)
FrameEvidence WheelInput::Impl::frameEvidence(const PoseProblem& pb) const {
  FrameEvidence e;
  e.t = pb.t;
  e.mono = &*mono;
  e.stereo = stereo ? &*stereo : nullptr;
  e.trusted = trustedOf(pb);
  e.observations = poseObservations(pb, e.trusted);
  const WheelPriorOfFrame w = wheelPriorOf(pb);
  e.wheels = w.delta;
  e.x_prev = w.x_prev;
  e.t_prev = w.t_prev;
  e.after_blind = w.from_anchor;
  e.x_guess = planarOf(pb.T_c_w);
  e.wheels_between = [this](double t0, double t1) -> std::optional<WheelDelta> {
    if (!covers(t0, t1)) return std::nullopt;
    return integrate(t0, t1);
  };
  return e;
}

ArbiterOptions WheelInput::Impl::arbiterOptions() const {
  ArbiterOptions a = ArbiterOptions::orbslam3().apply(params.tracking);
  a.wheel_gate = a.wheel_gate && !params.huber && params.map_from_depth;
  a.pose.huber = params.huber;
  return a;
}

bool WheelInput::optimisePose(const PoseProblem& pb, PoseSolution* out) {
  if (!optimisesPoses() || pb.matches.size() < 3) return false;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  if (m.segmenter) m.applyLabels();
  if (!m.params.wheels) return m.spatialPose(pb, out);
  m.makeEdges(pb);
  const std::size_t n = pb.matches.size();
  const FrameDecision d = m.arbiter.decide(m.frameEvidence(pb));
  if (d.slip) {
    m.markSlip(d.slip_from, pb.t);
    if (d.spin && (m.spins.empty() || m.spins.back() < pb.t)) m.spins.push_back(pb.t);
  }
  m.solved = {pb.t, d.x, true, d.slip};
  // Eq. 6: every match's latest whitened error (outliers included: that is the point).
  if (!m.params.huber) {
    for (std::size_t k = 0; k < n; ++k) m.reliability.observe(pb.matches[k].id, std::nullopt, d.result.error[k]);
  }
  out->T_c_w = m.cameraOf(d.x);
  // Here every match that did not place the pose is an outlier to ORB-SLAM3, one awaiting its labels
  // too. Flagged only where the gate rejects it (markFits), keyframes fell to upstream's count, but
  // `slip` missed its slip in one run of nine: ORB-SLAM3's keyframe rule must first count trusted
  // matches (patches/orbslam3/README.md).
  out->outlier.resize(n);
  for (std::size_t k = 0; k < n; ++k) out->outlier[k] = !d.result.inlier[k];
  out->inliers = d.result.inliers;
  out->slip = d.slip;
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

void WheelInput::setSegmenter(const std::shared_ptr<Segmenter>& segmenter) {
  if (!impl_) throw std::logic_error("WheelInput::setSegmenter: not configured (no RVWO keys in the settings)");
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->waiting.clear();
  // Two waiting at most (latest wins): a segmenter slower than keyframes skips some, never lags.
  impl_->segmenter = segmenter ? std::make_unique<AsyncSegmenter>(segmenter, 2) : nullptr;
}

bool WheelInput::segments() const { return impl_ && impl_->segmenter; }

void WheelInput::frameImage(const cv::Mat& image) {
  if (!segments()) return;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->frame_image = image.channels() == 3 || image.channels() == 4 ? image : cv::Mat();
}

void WheelInput::keyFrame(double t, const cv::Mat& image, const std::vector<KeyFrameFeature>& features) {
  if (!segments()) return;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const std::uint64_t id = m.keyframes_sent++;
  // A copy: ORB-SLAM3's image may share the caller's buffer, which the next frame may overwrite.
  cv::Mat seen;
  if (!m.frame_image.empty() && m.frame_image.size() == image.size()) {
    if (m.frame_image.channels() == 4)
      cv::cvtColor(m.frame_image, seen, cv::COLOR_BGRA2BGR);
    else
      seen = m.frame_image.clone();
  } else {
    seen = image.clone();
  }
  if (m.segmenter->submit(seen, FrameInfo{id, t})) m.waiting.emplace(id, features);
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
