// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// WheelInput's inside, shared by its files: wheel_input.cc (readings, prediction, the frame's pose,
// labels) and local_map.cc (the local and global maps through rvwo::solveWindow, the essential
// graph). Private to the plugin.
#pragma once

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
#include "rvwo/orbslam3/wheel_input.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/semantics/label_lookup.h"
#include "rvwo/semantics/onnx_segmenter.h"
#include "rvwo/semantics/shipped_model.h"
#include "rvwo/settings/settings.h"
#include "rvwo/tracking/frame_arbiter.h"
#include "rvwo/tracking/planar_pose.h"
#include "rvwo/tracking/spatial_pose.h"
#include "rvwo/tracking/wheel_checks.h"
#include "rvwo/tracking/window.h"

namespace rvwo::orbslam3 {

inline SE2 planar(const Eigen::Isometry3d& T) {
  return SE2(T.translation().x(), T.translation().y(), std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
}

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
    p.tracking.validate();
    arbiter = FrameArbiter(arbiterOptions());
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
  ReliabilityManager reliability;       // per map point id: eq. 6 from its latest whitened error
  std::optional<PinholeCamera> camera;  // made with the first problem (ORB-SLAM3's intrinsics)
  std::optional<Se2XyzMonoEdge> mono;
  std::optional<Se2XyzStereoEdge> stereo;
  // The wheels against vision, solve by solve. ORB-SLAM3 solves a frame up to twice (motion model,
  // then local map): the second solve refines the same frame and goes on with a slip its first one
  // found. (Judging it against the previous frame only measured no better: stereo slip ATE 0.0123
  // and 0.0137 m, against 0.0113 and 0.0169 m this way.)
  FrameArbiter arbiter;
  ArbiterOptions arbiterOptions() const;
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
  // ---- a frame's pose (optimisePose)
  struct WheelPriorOfFrame {
    Eigen::Vector3d x_prev = Eigen::Vector3d::Zero();  // the edge's first pose
    double t_prev = 0.0;                               // its time
    std::optional<WheelDelta> delta;
    bool from_anchor = false;  // after a stretch on the wheels alone
  };
  std::vector<char> trustedOf(const PoseProblem& pb) const;
  std::vector<PoseObservation> poseObservations(const PoseProblem& pb, const std::vector<char>& trusted) const;
  WheelPriorOfFrame wheelPriorOf(const PoseProblem& pb) const;
  FrameEvidence frameEvidence(const PoseProblem& pb) const;
  // Without wheels: the frame in 6-DoF under the points' kernels, and their errors to eq. 6.
  bool spatialPose(const PoseProblem& pb, PoseSolution* out);
  // The outlier flags ORB-SLAM3 gets: what the gate and the labels say of each match at the pose
  // solved (errors: whitened, per match); returns how many fit.
  int markFits(const PoseProblem& pb, const std::vector<double>& error, PoseSolution* out) const;
  // ---- the local map (optimiseLocalMap)
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

  // ---- labels
  SemanticPriors priors;
  std::unique_ptr<AsyncSegmenter> segmenter;
  cv::Mat frame_image;  // the frame's colour image (frameImage), for the keyframe it may become
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

}  // namespace rvwo::orbslam3
