// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/estimator/estimator.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "rvwo/ceres/barron_loss.h"
#include "rvwo/ceres/costs.h"
#include "rvwo/ceres/se2_manifold.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/estimator/features.h"
#include "rvwo/kernels/barron.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/semantics/label_lookup.h"
#include "rvwo/tracking/planar_pose.h"
#include "rvwo/tracking/wheel_checks.h"
#include "rvwo/tracking/window.h"

namespace rvwo::estimator {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Mono: new points are triangulated between a keyframe and this many keyframes before it.
constexpr int kTriangulationNeighbours = 5;

// One worker thread running tasks in the order given; submit() returns the result's future
// (an exception thrown by the task comes out of its get()).
class TaskQueue {
 public:
  TaskQueue() : thread_([this] { run(); }) {}
  ~TaskQueue() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }
  template <typename T>
  std::future<T> submit(std::function<T()> f) {
    auto task = std::make_shared<std::packaged_task<T()>>(std::move(f));
    std::future<T> result = task->get_future();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tasks_.emplace_back([task] { (*task)(); });
    }
    cv_.notify_one();
    return result;
  }

 private:
  void run() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
        if (tasks_.empty()) return;  // stop, and nothing left
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stop_ = false;
  std::thread thread_;
};

struct KeyFrame {
  std::uint64_t id = 0;
  double t = 0;
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // T_w_b as (x, y, theta)
  Features f;
  std::vector<std::int64_t> point;  // per feature: map point id, -1 none
  // Landmarks matched here but rejected by the pose's chi2 gate: not observations for the
  // bundle adjustment, but the keyframe's labels still speak of them (feature, point).
  std::vector<std::pair<int, std::uint64_t>> label_only;
  cv::Mat image;  // kept until segmented
  bool segmented = false;
  int tracked = 0;  // points tracked when it was made
};

struct MapPoint {
  std::uint64_t id = 0;
  Eigen::Vector3d P = Eigen::Vector3d::Zero();  // world
  cv::Mat descriptor;                           // 1 x 32
  int level = 0;                                // pyramid level where it was made ...
  double distance = 1;                          // ... and its distance from the camera then (m)
  std::map<std::uint64_t, int> obs;             // keyframe id -> feature index
  int visible = 0, found = 0;                   // frames it was predicted in view / matched in
  std::uint64_t first_kf = 0;
};

// Frames' poses: relative to their reference keyframe, so that refining keyframes moves them.
struct FrameRecord {
  double t;
  std::uint64_t ref_kf;
  SE2 T_kf_b;
  bool visual;
  bool slip = false;  // vision alone placed it (the wheels slipped)
};

struct Match {
  std::uint64_t point;
  int feature;
};

class Timings {
 public:
  void add(const std::string& stage, double ms) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = std::find_if(stages_.begin(), stages_.end(), [&](const auto& s) { return s.first == stage; });
    if (it == stages_.end()) {
      stages_.emplace_back(stage, std::vector<double>{});
      it = std::prev(stages_.end());
    }
    it->second.push_back(ms);
  }
  std::vector<std::pair<std::string, TimingStats>> stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::pair<std::string, TimingStats>> out;
    for (const auto& [name, v] : stages_) out.emplace_back(name, TimingStats::of(v));
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, std::vector<double>>> stages_;
};

}  // namespace

double Rig::bf() const { return baseline * camera->fx(); }

TimingStats TimingStats::of(std::vector<double> ms) {
  TimingStats s;
  s.count = ms.size();
  if (ms.empty()) return s;
  std::sort(ms.begin(), ms.end());
  double sum = 0;
  for (double x : ms) sum += x;
  s.mean = sum / ms.size();
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
  if (min_inliers < 6) fail("Estimator.MinInliers: >= 6");
  if (keyframe_max_frames < 1) fail("Estimator.KeyFrameMaxFrames: >= 1");
  if (!(keyframe_ratio > 0 && keyframe_ratio < 1)) fail("Estimator.KeyFrameRatio: in (0, 1)");
  if (window < 2) fail("Estimator.Window: >= 2");
  if (keep_keyframes < window + 1) fail("Estimator.KeepKeyFrames: > Estimator.Window");
  if (!(mono_max_mapping_lag >= 0)) fail("Estimator.MonoMaxMappingLag: >= 0 s");
  if (!(sigma_px > 0)) fail("Estimator.SigmaPx: > 0");
  if (!(mono_min_baseline > 0)) fail("Estimator.MonoMinBaseline: > 0");
  if (!(mono_min_parallax > 0 && mono_min_parallax < 45)) fail("Estimator.MonoMinParallax: in (0, 45) degrees");
  if (!(slip_hold >= 0)) fail("Estimator.SlipHold: >= 0 s");
  if (slip_hold_min_frames < 1) fail("Estimator.SlipHoldMinFrames: >= 1");
  if (!(slip_min_inliers >= 1)) fail("Estimator.SlipMinInliers: >= 1 (times Estimator.MinInliers)");
  if (!(trusted_max_ps > 0 && trusted_max_ps <= 1)) fail("Estimator.TrustedMaxPs: in (0, 1]");
  if (kernel == KernelChoice::kFixed && std::isnan(fixed_alpha)) fail("kernel fixed: alpha is NaN");
  if (!(calibration_period > 0)) fail("calibration_period: > 0 s");
  reliability.validate();
  wheel_noise.validate();
  drive.validate();
}

struct Estimator::Impl {
  Rig rig;
  EstimatorOptions opt;
  FeatureExtractor extractor;
  std::optional<Se2XyzEdge<3>> stereo_edge;  // stereo and RGB-D (rectified pinhole) only
  Se2XyzEdge<2> mono_edge;
  ReliabilityManager reliability;
  WheelOdometry odometry;
  std::mutex odometry_mutex;                             // the wheel buffer is written by tracking, read by mapping
  ceres_adapters::WheelCalibrationEstimate calibration;  // the odometry's, refined by local BA (same lock)
  bool has_odometry = false;
  std::shared_ptr<Segmenter> segmenter;
  std::unique_ptr<AsyncSegmenter> async;
  std::vector<int> dynamic_labels;
  std::function<void(const PoseEstimate&)> callback;
  Timings timings;

  // ---- map (guarded by map_mutex) ----
  mutable std::mutex map_mutex;
  std::map<std::uint64_t, KeyFrame> keyframes;         // in memory, by id (= time order)
  std::unordered_map<std::uint64_t, MapPoint> points;  // seen by keyframes in memory
  std::map<std::uint64_t, SE2> final_pose;             // keyframes that left memory
  std::vector<FrameRecord> frames;
  std::uint64_t next_kf = 0, next_point = 0;
  Report counters;

  // ---- tracking state (tracking thread only) ----
  // What tracking needs of a frame's images, made without the map: features, their stereo
  // matches or depth, and the grey image the segmenter will see.
  struct FrontEnd {
    Features f;
    cv::Mat raw_grey;  // before rectification (labels are rectified after)
  };
  // Frames waiting for the odometry to pass their time, with their front ends under way.
  struct PendingFrame {
    FrameInput in;
    std::future<FrontEnd> front_end;  // not valid: made when tracked (deterministic, wheel mode)
  };
  std::deque<PendingFrame> pending;
  // The front end runs one frame ahead of tracking in a thread of its own (not deterministic, no
  // images in wheel mode): while tracking matches and optimises frame k, frame k+1's features are
  // being extracted.
  std::unique_ptr<TaskQueue> front_end_queue;
  double last_t = -1;  // of the last processed frame
  SE2 last_pose;       // its T_w_b (absolute, refreshed from its reference keyframe)
  SE2 velocity;        // T_{k-1}_{k}: constant-velocity model without wheels
  int frames_since_kf = 0;
  bool has_last = false, last_visual = true;
  std::size_t slip_frames = 0;       // frames where vision overruled the wheels
  bool slipping = false;             // the last frame was one (tracking's)
  double last_slip_t = -1e300;       // the last such frame's time
  int slip_run = 0;                  // slip frames in a row, up to the last one
  bool holding = false;              // the last frame held the pose after a slip
  double wheels_doubted_t = -1e300;  // the last blind frame whose landmarks contradicted the wheels
  struct RelocalisedRun {
    double t = -1;      // its last frame
    Eigen::Vector3d x;  // that frame's pose
    int placed = 0;     // trusted inliers summed over the run
  } relocalised_run;    // relocalisations of MinInliers or more in a row, each where the last allows
  std::atomic<std::size_t> wheel_outliers{0};  // wheel edges local BA found wrong
  std::mutex slip_mutex;
  struct SlipMark {
    double t;
    bool spin;  // the robot about stood while the wheels went on (slipIsSpin)
  };
  std::deque<SlipMark> slip_marks;  // of those frames, since the oldest keyframe in memory
  // Mono: vision alone's recent poses (each frame's, where it placed the frame) over the stretch
  // wheelsStall judges, and how many frames in a row it has found the wheels stalled.
  static constexpr double kStallStretch = 0.2;  // s: 3 cm (kStallTravel) at 0.15 m/s
  static constexpr int kStallFrames = 5;        // a bump or a walker pulls vision alone off for
                                                // one or two stretches, not three (mono combined)
  std::deque<std::pair<double, Eigen::Vector3d>> vision_track;
  int stall_run = 0;

  struct SlipCount {
    int frames = 0, spins = 0;
  };
  SlipCount slipsBetween(double t0, double t1) {
    std::lock_guard<std::mutex> lock(slip_mutex);
    SlipCount n;
    for (const SlipMark& m : slip_marks) {
      if (m.t <= t0 || m.t > t1) continue;
      ++n.frames;
      n.spins += m.spin;
    }
    return n;
  }
  double added_t = -1e300;  // last frame added

  // ---- local mapping thread ----
  std::thread mapper;
  std::mutex queue_mutex;
  std::condition_variable queue_cv, idle_cv;
  // A keyframe waits for mapping. Only the newest is worth a local BA (the ones before it are in
  // its window), so a flag is the whole queue.
  bool pending_keyframe = false;
  bool stop = false, busy = false;
  double queued_kf_t = -1e300;  // the time of the keyframe queued last

  Impl(const Rig& r, const EstimatorOptions& o, std::shared_ptr<Segmenter> seg)
      : rig(r),
        opt(o),
        extractor(FeatureParams{o.features, o.scale_factor, o.levels, o.fast_threshold, 8, 6}),
        mono_edge(*r.camera, r.T_b_c),
        reliability(o.reliability),
        odometry(o.wheel_noise, r.T_b_o),
        segmenter(o.semantics ? std::move(seg) : nullptr) {
    if (r.sensor != Sensor::kMono) stereo_edge.emplace(*r.camera, r.T_b_c, r.bf());
    if (segmenter && !opt.deterministic) async = std::make_unique<AsyncSegmenter>(segmenter, 4, 256);
    dynamic_labels = opt.priors.dynamicLabels();
    if (!opt.deterministic) mapper = std::thread([this] { mappingLoop(); });
    if (!opt.deterministic && opt.mode != Mode::kWheel) front_end_queue = std::make_unique<TaskQueue>();
  }

  ~Impl() { stopMapper(); }

  void stopMapper() {
    {
      std::lock_guard<std::mutex> lock(queue_mutex);
      stop = true;
    }
    queue_cv.notify_all();
    if (mapper.joinable()) mapper.join();
  }

  // ================= helpers =================
  SE2 kfPose(std::uint64_t id) const {
    auto it = keyframes.find(id);
    if (it != keyframes.end()) return SE2::fromVector(it->second.x);
    auto f = final_pose.find(id);
    return f != final_pose.end() ? f->second : SE2();
  }

  double kernelAlpha(std::uint64_t point) const {
    switch (opt.kernel) {
      case KernelChoice::kHuber:
        return 1.0;  // unused
      case KernelChoice::kFixed:
        return opt.fixed_alpha;
      case KernelChoice::kAdaptive:
        return reliability.alpha(point);
    }
    return 1.0;
  }

  // A landmark no label has called dynamic (P_s below Estimator.TrustedMaxPs),
  // and, with labels coming from the segmentation thread, not one whose keyframe still waits for
  // its labels: a keyframe's new points are the closest features, often a walker's, and counted
  // as trusted for the frame or two until its labels came they placed frames and made vision
  // flicker (threaded RGB-D dynamic: trusted matches 176, 26, 164, 17 in consecutive frames).
  // (Map lock held.)
  bool isTrusted(std::uint64_t point) const {
    if (async) {
      auto p = points.find(point);
      if (p != points.end()) {
        auto kf = keyframes.find(p->second.first_kf);
        if (kf != keyframes.end() && !kf->second.segmented) return false;
      }
    }
    const std::optional<LandmarkReliability> r = reliability.get(point);
    return !r || r->ps < opt.trusted_max_ps;
  }
  std::vector<char> trustedOf(const std::vector<Match>& matches) const {
    std::vector<char> trusted(matches.size());
    for (std::size_t k = 0; k < matches.size(); ++k) trusted[k] = isTrusted(matches[k].point);
    return trusted;
  }

  // A landmark the adaptive (or a fixed alpha = -inf) kernel rejects: its edges leave the problem.
  bool rejected(double alpha) const { return opt.kernel != KernelChoice::kHuber && alpha == -BarronKernel::kInfinity; }

  // The SE(2)-XYZ edge of an observation (u, v, u_R) (N = 3) or (u, v) (N = 2), and the
  // square-root information of its covariance at x (eq. 10: out-of-plane inflation).
  template <int N>
  const Se2XyzEdge<N>& edge() const {
    if constexpr (N == 3) {
      return *stereo_edge;
    } else {
      return mono_edge;
    }
  }
  template <int N>
  Eigen::Matrix<double, N, N> sqrtInformation(const Eigen::Vector3d& x, const Eigen::Vector3d& P, double sigma) const {
    return edge<N>().sqrtInformation(x, P, sigma, opt.out_of_plane);
  }
  // Whitened chi2 of observation z = (u, v, u_R) at x (u_R unused unless stereo), with the
  // information at x (rvwo::whitenedChi2); false when the point does not project.
  bool chi2(bool stereo, const Eigen::Vector3d& x, const Eigen::Vector3d& P, const Eigen::Vector3d& z, double sigma,
            double* out) const {
    PoseObservation o;
    o.P_w = P;
    o.z = z;
    o.stereo = stereo;
    o.sigma_px = sigma;
    return whitenedChi2(mono_edge, stereo_edge ? &*stereo_edge : nullptr, o, x, opt.out_of_plane, out);
  }
  // The camera's pose in the world at the robot pose x = (x, y, theta).
  Eigen::Isometry3d T_w_c(const Eigen::Vector3d& x) const { return SE2::fromVector(x).isometry3() * rig.T_b_c; }

  // Predicted (u, v, u_R) of P_w from x (mono: u_R = -1); false when it does not project.
  bool predict(const Eigen::Vector3d& x, const Eigen::Vector3d& P_w, Eigen::Vector3d* h) const {
    if (stereo_edge) return stereo_edge->predict(x, P_w, h);
    Eigen::Vector2d uv;
    if (!mono_edge.predict(x, P_w, &uv)) return false;
    *h << uv, -1.0;
    return true;
  }
  // Observation (u, v, u_R) of a frame's feature (u_R = -1 without stereo or depth).
  static Eigen::Vector3d observation(const Features& f, int i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    return Eigen::Vector3d(kp.pt.x, kp.pt.y, f.u_right[i]);
  }

  bool hasStereo(const Features& f, int i) const { return rig.sensor != Sensor::kMono && f.u_right[i] >= 0; }

  // Predicted pyramid level of a point seen from distance d.
  int predictLevel(const MapPoint& p, double d) const {
    const int l = p.level + static_cast<int>(std::lround(std::log(p.distance / d) / std::log(opt.scale_factor)));
    return std::clamp(l, 0, opt.levels - 1);
  }

  // ================= tracking =================
  std::vector<Match> searchByProjection(const Features& f, const Eigen::Vector3d& x, double radius_scale) {
    std::vector<Match> matches;
    std::vector<int> best_dist(f.size(), 256);
    std::vector<std::int64_t> best_point(f.size(), -1);
    const Eigen::Isometry3d T_c_w = T_w_c(x).inverse();
    for (auto& [id, p] : points) {
      const Eigen::Vector3d P_c = T_c_w * p.P;
      const double d = P_c.norm();
      if (P_c.z() < 0.1 || d > 3 * p.distance || d < p.distance / 3) continue;
      Eigen::Vector3d h;  // (u, v, u_R); mono: (u, v, unused)
      if (!predict(x, p.P, &h)) continue;
      if (h.x() < 0 || h.y() < 0 || h.x() >= rig.width || h.y() >= rig.height) continue;
      ++p.visible;
      const int level = predictLevel(p, d);
      const float r = static_cast<float>(opt.search_radius * radius_scale * std::pow(opt.scale_factor, level));
      BestTwo match;
      for (int i : f.near(static_cast<float>(h.x()), static_cast<float>(h.y()), r, level - 1, level + 1)) {
        if (rig.sensor != Sensor::kMono && f.u_right[i] >= 0 && std::fabs(f.u_right[i] - h.z()) > r) continue;
        match.offer(hammingDistance(p.descriptor, f.descriptors.row(i)), i);
      }
      if (match.index < 0 || match.best > 50 || match.best > 0.9 * match.second) continue;
      if (match.best < best_dist[match.index]) {
        best_dist[match.index] = match.best;
        best_point[match.index] = static_cast<std::int64_t>(id);
      }
    }
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (best_point[i] >= 0) matches.push_back({static_cast<std::uint64_t>(best_point[i]), static_cast<int>(i)});
    }
    return matches;
  }

  // Relocalisation against the map in memory (stereo and RGB-D), when the projection search
  // finds nothing: after a blind stretch the wheels' prediction may be far off (a slip while a
  // walker covered the view left it 0.6 rad off, and the map was started anew from there). Each
  // feature with depth is matched by descriptor with the trusted landmarks (Hamming <= 50, clearly
  // better than the second best, at the same height within 0.2 m: the robot stays on its floor);
  // two pairs fix an SE(2) pose from their ground-plane positions (RANSAC, a fixed seed); the best
  // pose, if 3 x Estimator.MinInliers pairs agree with it, seeds the projection search and the pose
  // optimisation. (Map lock held.)
  std::optional<Eigen::Vector3d> relocalise(const Features& f) {
    if (rig.sensor == Sensor::kMono) return std::nullopt;
    // A seed: the projection search and the pose optimisation after it decide.
    const std::size_t enough = static_cast<std::size_t>(opt.min_inliers);
    std::vector<std::uint64_t> ids;
    cv::Mat map_descriptors;
    for (const auto& [id, p] : points) {
      if (!isTrusted(id) || rejected(kernelAlpha(id))) continue;
      ids.push_back(id);
      map_descriptors.push_back(p.descriptor);
    }
    std::vector<int> with_depth;
    cv::Mat frame_descriptors;
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (f.depth[i] <= 0) continue;
      with_depth.push_back(static_cast<int>(i));
      frame_descriptors.push_back(f.descriptors.row(static_cast<int>(i)));
    }
    if (ids.size() < enough || with_depth.size() < enough) return std::nullopt;
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_HAMMING).knnMatch(frame_descriptors, map_descriptors, knn, 2);
    struct Pair {
      Eigen::Vector2d p_b, q_w;  // the feature in the robot's frame, its landmark in the world's
      double tolerance;          // m: stereo depth grows less sure with distance
    };
    std::vector<Pair> pairs;
    for (std::size_t k = 0; k < knn.size(); ++k) {
      if (knn[k].empty() || knn[k][0].distance > 50) continue;
      if (knn[k].size() > 1 && knn[k][0].distance > 0.8f * knn[k][1].distance) continue;
      const int i = with_depth[k];
      const cv::KeyPoint& kp = f.keypoints[i];
      const Eigen::Vector3d P_b = rig.T_b_c * (f.depth[i] * rig.camera->unproject(Eigen::Vector2d(kp.pt.x, kp.pt.y)));
      const Eigen::Vector3d& P_w = points.at(ids[knn[k][0].trainIdx]).P;
      if (std::fabs(P_b.z() - P_w.z()) > 0.2) continue;
      pairs.push_back({P_b.head<2>(), P_w.head<2>(), 0.05 + 0.02 * f.depth[i]});
    }
    if (pairs.size() < enough) return std::nullopt;
    std::uint64_t state = 0x9E3779B97F4A7C15ull;  // a fixed seed: the same frame, the same answer
    auto draw = [&] {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      return static_cast<std::size_t>(state >> 33) % pairs.size();
    };
    std::size_t best = 0;
    SE2 T_best;
    for (int it = 0; it < 300; ++it) {
      const Pair &a = pairs[draw()], &b = pairs[draw()];
      const Eigen::Vector2d dp = b.p_b - a.p_b, dq = b.q_w - a.q_w;
      if (dp.norm() < 0.3 || std::fabs(dp.norm() - dq.norm()) > a.tolerance + b.tolerance) continue;
      const double theta = std::atan2(dq.y(), dq.x()) - std::atan2(dp.y(), dp.x());
      const SE2 T(a.q_w - rotation2(theta) * a.p_b, theta);
      std::size_t agree = 0;
      for (const Pair& p : pairs) agree += (T.act(p.p_b) - p.q_w).norm() < p.tolerance;
      if (agree > best) {
        best = agree;
        T_best = T;
      }
    }
    if (best < enough) return std::nullopt;
    return T_best.vector();
  }

  // The frame's matches as the pose solver takes them, each with its landmark's kernel. (Map lock
  // held.)
  std::vector<PoseObservation> poseObservations(const Features& f, const std::vector<Match>& matches) const {
    std::vector<PoseObservation> obs(matches.size());
    for (std::size_t k = 0; k < matches.size(); ++k) {
      PoseObservation& o = obs[k];
      o.P_w = points.at(matches[k].point).P;
      o.z = observation(f, matches[k].feature);
      o.stereo = hasStereo(f, matches[k].feature);
      o.sigma_px = opt.sigma_px * std::pow(opt.scale_factor, f.keypoints[matches[k].feature].octave);
      o.alpha = kernelAlpha(matches[k].point);
      // With the adaptive kernel a landmark any label has called dynamic does not place a frame,
      // though its alpha (0.51 after one person label, by the weights of ReliabilityParams) keeps
      // it in the map: a frame's pose is cheap to get wrong the other way (the wheels carry it),
      // while walkers' landmarks, freshly labelled and given depth, may outnumber the static ones
      // (dynamic 30 s cut, 8-10 s: a 0.4 deg yaw error; 0.135 -> 0.058 % of the path). Beyond
      // the paper, which weighs every landmark by its alpha alone. Huber and a fixed alpha know
      // nothing of labels.
      o.usable = !rejected(o.alpha) && (opt.kernel != KernelChoice::kAdaptive || isTrusted(matches[k].point));
    }
    return obs;
  }
  PlanarPoseOptions poseOptions() const {
    PlanarPoseOptions po;
    po.huber = opt.kernel == KernelChoice::kHuber;
    po.barron_scale = opt.barron_scale;
    po.out_of_plane = opt.out_of_plane;
    return po;
  }

  // Pose-only optimisation on SE(2): iteratively reweighted Gauss-Newton with each landmark's
  // kernel, in rounds (ORB-SLAM's): after each, residuals beyond the chi2 gate are outliers for
  // the next. prior: the wheel edge from the previous frame (fixed) to this one.
  int optimisePose(const Features& f, const std::vector<Match>& matches, const std::optional<WheelEdge>& prior,
                   const Eigen::Vector3d& x_prev, Eigen::Vector3d* x, std::vector<char>* inlier,
                   std::vector<double>* errors) {
    const WheelPrior wheel{prior ? &*prior : nullptr, x_prev};
    PlanarPoseResult r = optimisePlanarPose(mono_edge, stereo_edge ? &*stereo_edge : nullptr,
                                            poseObservations(f, matches), wheel, poseOptions(), x);
    inlier->swap(r.inlier);
    errors->swap(r.error);
    return r.inliers;
  }

  // The wheels' motion between t0 and t1, clipped to the readings there are; none in vo mode or
  // without odometry. (Tracking writes the wheel buffer, mapping reads it: under its lock.)
  // Integrated with the calibration as estimated so far.
  std::optional<WheelDelta> wheelDelta(double t0, double t1) {
    std::lock_guard<std::mutex> lock(odometry_mutex);
    if (!has_odometry || opt.mode == Mode::kVo || odometry.empty()) return std::nullopt;
    t0 = std::max(t0, odometry.firstTime());
    t1 = std::min(t1, odometry.lastTime());
    if (!(t1 > t0)) return std::nullopt;
    return odometry.integrate(t0, t1, calibration.c);
  }

  FrontEnd frontEnd(const FrameInput& in) {
    FrontEnd out;
    auto t0 = Clock::now();
    Features& f = out.f;
    const cv::Mat raw_grey = toGrey(in.image);
    out.raw_grey = raw_grey;
    cv::Mat grey = raw_grey, grey_right = rig.sensor == Sensor::kStereo ? toGrey(in.right) : cv::Mat();
    if (rig.rectification) {
      const cv::Mat raw_right = grey_right;
      grey = cv::Mat();  // fresh buffers: cv::remap cannot work in place
      grey_right = cv::Mat();
      rig.rectification->rectify(raw_grey, raw_right, &grey, &grey_right);
    }
    if (rig.sensor == Sensor::kStereo) {
      f = extractor.extract(grey);
      timings.add("features", msSince(t0));
      auto t1 = Clock::now();
      matchStereo(grey, grey_right, rig.bf(), 0.5, rig.bf() / 0.2, &f);
      timings.add("stereo", msSince(t1));
    } else {
      f = extractor.extract(grey);
      if (rig.sensor == Sensor::kRgbd) depthFromImage(in.depth, rig.depth_factor, rig.bf(), &f);
      timings.add("features", msSince(t0));
    }
    return out;
  }

  // One frame's tracking as it goes through the steps of processFrame.
  struct FrameWork {
    double t = 0;
    std::optional<WheelDelta> delta;  // the wheels since the last frame (none: vo, or no readings)
    SE2 predicted;                    // where they (or the motion model) put the robot
    std::optional<WheelEdge> prior;   // their edge from the last frame (vw)
    Features f;
    cv::Mat raw_grey;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();  // the pose being solved
    std::vector<Match> matches;
    std::vector<char> inlier, trusted;  // per match
    std::vector<double> errors;         // per match: whitened error
    int inliers = 0;
    int candidates = 0;            // trusted matches
    int to_place = 0;              // trusted inliers that place the frame
    int vision_alone_placed = -1;  // trusted inliers of vision alone, when the slip check solved it
    bool strained = false;         // vision strains the wheel edge from the last frame
    bool was_slipping = false;
    bool track_vision = false;  // mono: vision alone's own track is kept
    bool visual = false, after_slip = false, contradicts_wheels = false;
    int countTrusted(const std::vector<char>& in) const {
      int n = 0;
      for (std::size_t k = 0; k < in.size(); ++k) n += in[k] && trusted[k];
      return n;
    }
  };

  // The frame's pipeline: predict from the wheels, extract features (made ahead in the front
  // end's thread), track the local map (match, solve, decide wheels or vision), relocalise when
  // still blind, hold after a slip, then keep the pose and decide on a keyframe.
  void processFrame(const FrameInput& in, std::future<FrontEnd> front_end = {}) {
    FrameWork w;
    w.t = in.timestamp;
    // Labels that have come (threaded): applied now rather than at the next local BA, a keyframe
    // or more later, so that a walker's fresh landmarks stop counting as vision sooner.
    if (async) applyLabels(false);
    waitForMappingLag(w.t);
    predictFrame(&w);
    FrameRecord record{w.t, 0, SE2(), false};
    if (opt.mode == Mode::kWheel) {
      {
        std::lock_guard<std::mutex> lock(map_mutex);
        if (final_pose.empty()) final_pose[0] = SE2();  // the world's origin
      }
      record.ref_kf = 0;
      record.T_kf_b = w.predicted;
      finishFrame(record, w.t);
      return;
    }
    FrontEnd fe = front_end.valid() ? front_end.get() : frontEnd(in);
    w.f = std::move(fe.f);
    w.raw_grey = fe.raw_grey;

    std::unique_lock<std::mutex> lock(map_mutex);
    if (keyframes.empty() && final_pose.empty()) {
      // The first keyframe at the world's origin, points from stereo or depth (metric: no visual
      // initialisation to check against the wheels).
      const int made = createKeyFrame(w.t, Eigen::Vector3d::Zero(), std::move(w.f), {}, w.raw_grey);
      record.ref_kf = next_kf - 1;
      record.visual = made > 0;
      lock.unlock();
      queueKeyFrame(w.t);
      finishFrame(record, w.t);
      return;
    }
    trackLocalMap(&w);
    // Do this frame's own trusted landmarks say the wheels are wrong? Judged here, on the match
    // set the slip check counted, before a relocalisation replaces it (see the blind keyframe).
    w.contradicts_wheels = w.candidates >= opt.min_inliers / 2 && w.countTrusted(w.inlier) < 0.6 * w.candidates &&
                           w.vision_alone_placed >= 0.6 * w.candidates;
    if (!w.visual && !last_visual) relocaliseBlindFrame(&w);
    holdAfterSlip(&w);
    const bool make_kf = keepFrame(&w, &record);
    lock.unlock();
    if (make_kf) queueKeyFrame(w.t);
    last_visual = w.visual;
    finishFrame(record, w.t);
  }

  // The pose the wheels predict from the last frame's (refreshed from its reference keyframe,
  // which local BA may have moved), or without them the motion model's.
  void predictFrame(FrameWork* w) {
    if (!has_last) return;
    {
      std::lock_guard<std::mutex> lock(map_mutex);
      const FrameRecord& prev = frames.back();
      last_pose = kfPose(prev.ref_kf) * prev.T_kf_b;
    }
    w->delta = wheelDelta(last_t, w->t);
    w->predicted = w->delta ? last_pose * w->delta->pose() : last_pose * (opt.mode == Mode::kVo ? velocity : SE2());
  }

  // Matches to the local map, the pose solved with the wheel edge, then the wheels against vision:
  // the slip check and the wheel gate. (Map lock held.)
  void trackLocalMap(FrameWork* w) {
    auto t2 = Clock::now();
    w->x = w->predicted.vector();
    w->matches = searchByProjection(w->f, w->x, last_visual ? 1.0 : 2.0);
    if (static_cast<int>(w->matches.size()) < 2 * opt.min_inliers && !w->delta) {
      w->matches = searchByProjection(w->f, w->x, 3.0);  // no wheels: the motion model may be far off
    }
    timings.add("match", msSince(t2));
    auto t3 = Clock::now();
    if (w->delta && opt.mode == Mode::kVw) {
      try {
        w->prior.emplace(*w->delta);
      } catch (const std::invalid_argument&) {  // degenerate covariance (no motion, no floor)
      }
    }
    w->was_slipping = slipping;
    slipping = false;  // until this frame says otherwise (a frame without matches ends a slip)
    // Vision counts only landmarks no label has called dynamic (in the slip test and for a visual
    // frame): a walker close in front fills the view with its own landmarks.
    w->trusted = trustedOf(w->matches);
    w->candidates = static_cast<int>(std::count(w->trusted.begin(), w->trusted.end(), 1));
    // Trusted inliers a frame needs for vision to place it. Coming back from the wheels, vision
    // must be convincingly back (the first frames after a blackout carry few, poorly placed
    // matches: one such frame put the pose 6 cm off).
    w->to_place = (last_visual ? 1 : 3) * opt.min_inliers;
    w->track_vision = w->prior && rig.sensor == Sensor::kMono && !w->matches.empty();
    if (!w->track_vision) {  // a gap in vision alone's track: it starts again
      vision_track.clear();
      stall_run = 0;
    }
    if (!w->matches.empty()) {
      w->inliers = optimisePose(w->f, w->matches, w->prior, last_pose.vector(), &w->x, &w->inlier, &w->errors);
      w->strained = w->prior && wheelEdgeStrained(*w->prior, last_pose.vector(), w->x);
      checkSlip(w);
      applyWheelGate(w);
    }
    timings.add("pose", msSince(t3));
    // (Trusted inliers only: following a walker's landmarks is following the walker.)
    w->visual = w->countTrusted(w->inlier) >= w->to_place;
  }

  // Mono: vision alone's own track over the last kStallStretch, and whether it shows wheels that
  // stall (wheelsStall) kStallFrames in a row, this frame too seeing less than half its claim (a
  // stretch over a stall's end still reads as stalled for up to half its length once the robot
  // has driven on: 4 frames after a 1 s mono slip, 2.4 cm).
  bool trackVisionAlone(const FrameWork& w, const Eigen::Vector3d& x_vision, const std::vector<char>& inlier_v) {
    while (!vision_track.empty() && vision_track.front().first < w.t - kStallStretch - 1e-6) {
      vision_track.pop_front();
    }
    if (w.countTrusted(inlier_v) < w.to_place) {
      vision_track.clear();  // vision alone did not place this frame: the track starts again
      stall_run = 0;
    } else {
      bool stall = false;
      if (!vision_track.empty() && w.t - vision_track.front().first >= 0.75 * kStallStretch) {
        if (const std::optional<WheelDelta> stretch = wheelDelta(vision_track.front().first, w.t)) {
          const SE2 T_vision = SE2::fromVector(vision_track.front().second).inverse() * SE2::fromVector(x_vision);
          stall = wheelsStall(*stretch, T_vision);
        }
      }
      stall_run = stall ? stall_run + 1 : 0;
      vision_track.emplace_back(w.t, x_vision);
    }
    return stall_run >= kStallFrames &&
           stallSeen(*w.delta, last_pose.inverse() * SE2::fromVector(x_vision)) < kStallRatio;
  }

  // The slip check (rvwo::decideSlip): the wheels' motion against vision alone's, started where
  // the robot was. When the wheels spin in place (or skid) every static landmark disagrees with
  // them, so vision alone explains clearly more: it wins and the wheel edge is dropped for this
  // frame. Among walkers the wheels side with the static landmarks and keep the pose. Mono solves
  // vision alone every frame: its own track shows wheels that stall, which mono's counts of one
  // frame cannot. (Map lock held.)
  void checkSlip(FrameWork* w) {
    Eigen::Vector3d x_vision = last_pose.vector();
    std::vector<char> inlier_v;
    std::vector<double> errors_v;
    int inliers_v = 0;
    const auto solveVisionAlone = [&] {
      inliers_v = optimisePose(w->f, w->matches, std::nullopt, last_pose.vector(), &x_vision, &inlier_v, &errors_v);
    };
    bool stalled = false;
    if (w->track_vision) {
      solveVisionAlone();
      stalled = trackVisionAlone(*w, x_vision, inlier_v);
    }
    if (!w->prior || !(slipWorthChecking(w->was_slipping, w->strained, w->matches.size(), w->inliers) || stalled))
      return;
    if (!w->track_vision) solveVisionAlone();
    // Counting only landmarks no label has called dynamic: a walker close by, freshly mapped, once
    // explained 376 of 422 matches and took vision alone 25 cm off in four frames.
    SlipEvidence e;
    e.wheels = &*w->delta;
    e.T_b0_b1_fused = last_pose.inverse() * SE2::fromVector(w->x);
    e.T_b0_b1_vision = last_pose.inverse() * SE2::fromVector(x_vision);
    e.fused_inliers = w->countTrusted(w->inlier);
    e.vision_inliers = w->countTrusted(inlier_v);
    w->vision_alone_placed = e.vision_inliers;
    e.candidates = w->candidates;
    e.strained = w->strained;
    e.stalled = stalled;
    e.was_slipping = w->was_slipping;
    e.from_vision_alone = w->was_slipping;  // the previous frame's pose was vision alone's
    // Only vision that would place the frame overrules the wheels (mono, blind in a turn among
    // walkers and bumps, called frames slips that vision could not place).
    e.min_to_go_on = w->to_place;
    e.min_to_start = std::max(w->to_place, static_cast<int>(std::ceil(opt.slip_min_inliers * opt.min_inliers)));
    // Mono: a slip that starts farther back than this frame's claim, its tolerance and a skid says
    // the frames before took the wheels' side; so strong a claim needs vision that places the
    // frame firmly (docs/decisions/0009).
    if (w->track_vision && !w->was_slipping && missBeyondTheClaim(*w->delta, e.T_b0_b1_vision)) {
      e.min_to_start = std::max(e.min_to_start, 5 * opt.min_inliers);
    }
    if (!decideSlip(e)) return;
    slipping = true;
    w->x = x_vision;
    w->inliers = inliers_v;
    w->inlier.swap(inlier_v);
    w->errors.swap(errors_v);
    ++slip_frames;
    last_slip_t = w->t;
    // A hold goes on with the slip it held: vision back for a frame or two between blind
    // stretches, a walker passing in front of the spinning robot, is the same slip, and the
    // blindness after it holds again (docs/decisions/0003).
    slip_run = (w->was_slipping || holding) ? slip_run + 1 : 1;
    std::lock_guard<std::mutex> slock(slip_mutex);
    slip_marks.push_back({w->t, slipIsSpin(*w->delta, e.T_b0_b1_vision)});
  }

  // The wheel gate (Estimator.WheelGate; adaptive kernel, stereo and RGB-D:
  // rvwo::solveFromTheWheels; docs/decisions/0002). Not when vision comes back after frames on
  // the wheels: there it corrects their drift. (Map lock held.)
  void applyWheelGate(FrameWork* w) {
    PlanarPoseResult gated;
    if (opt.wheel_gate && opt.kernel == KernelChoice::kAdaptive && rig.sensor != Sensor::kMono && w->strained &&
        !slipping && last_visual &&
        solveFromTheWheels(mono_edge, stereo_edge ? &*stereo_edge : nullptr, poseObservations(w->f, w->matches),
                           WheelPrior{&*w->prior, last_pose.vector()}, poseOptions(), w->predicted.vector(), w->trusted,
                           w->to_place, &w->x, &gated)) {
      w->inliers = gated.inliers;
      w->inlier.swap(gated.inlier);
      w->errors.swap(gated.error);
      ++counters.wheel_gated;
    }
  }

  // Still blind after a stretch on the wheels: their prediction may be too far off for the
  // projection search, the map in memory may still be in view. Only trusted landmarks place the
  // frame (walkers' landmarks a label has seen, still inliers under their kernel, would pull the
  // pose along). Believed off the wheels' way only on overwhelming agreement: fewer than 3 x
  // MinInliers in a frame, but 4 x over a run of frames that agree where each frame's wheel motion
  // allows (walkers covering most of the view leave 20-50 static landmarks, each frame's
  // relocalisation another set of them). (Map lock held.)
  void relocaliseBlindFrame(FrameWork* w) {
    auto t5 = Clock::now();
    if (const std::optional<Eigen::Vector3d> x_map = relocalise(w->f)) {
      w->x = *x_map;
      w->matches = searchByProjection(w->f, w->x, 1.0);
      w->matches.erase(
          std::remove_if(w->matches.begin(), w->matches.end(), [&](const Match& m) { return !isTrusted(m.point); }),
          w->matches.end());
      w->inliers = optimisePose(w->f, w->matches, std::nullopt, w->x, &w->x, &w->inlier, &w->errors);
      w->trusted = trustedOf(w->matches);
      const int placed = w->countTrusted(w->inlier);
      int run = 0;  // trusted inliers summed over the agreeing relocalisations ending here
      if (placed >= opt.min_inliers) {
        const bool agrees =
            relocalised_run.placed > 0 && relocalised_run.t == last_t && w->delta &&
            onTheClaimedWay(*w->delta, SE2::fromVector(relocalised_run.x).inverse() * SE2::fromVector(w->x));
        run = (agrees ? relocalised_run.placed : 0) + placed;
        relocalised_run = {w->t, w->x, run};
      }
      const bool enough = placed >= 3 * opt.min_inliers || (run > placed && run >= 4 * opt.min_inliers);
      w->visual = enough && (placed >= 10 * opt.min_inliers || onTheWheelsWay(w->x, w->t));
      if (w->visual) ++counters.relocalisations;
    }
    timings.add("relocalise", msSince(t5));
  }

  // Blind right after a slip, the wheels are the last to trust: the pose stays where vision left
  // it (for at most Estimator.SlipHold), and its frames count as the spin they hold. Only a blind
  // stretch that starts in the slip holds: once vision has seen the robot drive on, the slip is
  // over (docs/decisions/0009).
  void holdAfterSlip(FrameWork* w) {
    w->after_slip = !w->visual && !slipping && w->t - last_slip_t <= opt.slip_hold &&
                    slip_run >= opt.slip_hold_min_frames && (holding || w->was_slipping);
    holding = w->after_slip;
    if (!w->after_slip) return;
    // Held still while the wheels went on, as far as the map knows: a spin, whose wheel edge sits
    // out local BA's first round and comes back in the second only if vision's keyframes agree
    // with it (docs/decisions/0003).
    std::lock_guard<std::mutex> slock(slip_mutex);
    slip_marks.push_back({w->t, true});
  }

  // The frame's pose (vision's, held, or the wheels'), its landmarks' reliabilities (eq. 6), and a
  // keyframe if one is due. Returns whether one was made. (Map lock held.)
  bool keepFrame(FrameWork* w, FrameRecord* record) {
    const SE2 T_w_b = w->visual ? SE2::fromVector(w->x) : w->after_slip ? last_pose : w->predicted;
    std::vector<std::int64_t> point_of(w->f.size(), -1);
    if (w->visual) {
      for (std::size_t k = 0; k < w->matches.size(); ++k) {
        if (!w->inlier[k]) continue;
        MapPoint& p = points.at(w->matches[k].point);
        ++p.found;
        point_of[w->matches[k].feature] = static_cast<std::int64_t>(p.id);
      }
    }
    // Eq. 6: every matched landmark's latest whitened error (outliers included: that is the point).
    if (w->visual && opt.kernel == KernelChoice::kAdaptive) {
      for (std::size_t k = 0; k < w->matches.size(); ++k)
        reliability.observe(w->matches[k].point, std::nullopt, w->errors[k]);
    }
    if (w->visual && !last_visual && has_last) spreadCorrection(T_w_b * w->predicted.inverse(), w->t);
    // Features matched to an untrusted landmark (adaptive kernel): a walker's, or one whose labels
    // are still to come. They neither ask for a keyframe (a walker close in front is forever
    // "close and untracked") nor give it a second, fresh landmark of the same walker.
    std::vector<char> on_walker(w->f.size(), 0);
    if (opt.kernel == KernelChoice::kAdaptive) {
      for (std::size_t k = 0; k < w->matches.size(); ++k) on_walker[w->matches[k].feature] |= !w->trusted[k];
    }
    ++frames_since_kf;
    const std::uint64_t ref = std::prev(keyframes.end())->first;
    const KeyFrame& ref_kf = keyframes.at(ref);
    const bool make_kf = keyFrameDue(*w, T_w_b, point_of, on_walker, ref_kf);
    if (make_kf) {
      auto t4 = Clock::now();
      std::vector<std::pair<int, std::uint64_t>> label_only;
      for (std::size_t k = 0; w->visual && k < w->matches.size(); ++k) {
        if (!w->inlier[k]) label_only.emplace_back(w->matches[k].feature, w->matches[k].point);
      }
      createKeyFrame(w->t, T_w_b.vector(), std::move(w->f), point_of, w->raw_grey, w->inliers, on_walker);
      keyframes.at(next_kf - 1).label_only = std::move(label_only);
      record->ref_kf = next_kf - 1;
      record->T_kf_b = SE2();
      timings.add("keyframe", msSince(t4));
    } else {
      record->ref_kf = ref;
      record->T_kf_b = SE2::fromVector(ref_kf.x).inverse() * T_w_b;
    }
    record->visual = w->visual;
    record->slip = w->visual && slipping;
    return make_kf;
  }

  // ORB-SLAM's keyframe rules with RVWO's exceptions (docs/estimator.md, rule 11). Visual: every
  // Estimator.KeyFrameMaxFrames frames, when the reference keyframe's points are less than
  // Estimator.KeyFrameRatio tracked, or for close untracked features, but not in a slip nor while
  // vision strains the wheel edge (a keyframe made at a pose the wheels pulled along moves the map
  // with them). Blind: a keyframe at the wheels' pose restarts the map once there is texture,
  // unless it holds after a slip or the landmarks in view doubt the wheels. (Map lock held.)
  bool keyFrameDue(const FrameWork& w, const SE2& T_w_b, const std::vector<std::int64_t>& point_of,
                   const std::vector<char>& on_walker, const KeyFrame& ref_kf) {
    int close_tracked = 0, close_untracked = 0;
    const double close = opt.max_depth_baselines * rig.baseline;
    for (std::size_t i = 0; i < w.f.size(); ++i) {
      if (w.f.depth[i] <= 0 || w.f.depth[i] > close || (point_of[i] < 0 && on_walker[i])) continue;
      (point_of[i] >= 0 ? close_tracked : close_untracked)++;
    }
    if (w.visual) {
      wheels_doubted_t = -1e300;
      return frames_since_kf >= opt.keyframe_max_frames ||
             (frames_since_kf >= 2 && w.inliers < opt.keyframe_ratio * ref_kf.tracked) ||
             (!slipping && !w.strained && close_tracked < 100 && close_untracked > 70);
    }
    if (rig.sensor == Sensor::kMono) {
      // Mono: once the wheels have moved the camera far enough for a baseline.
      return (T_w_c(T_w_b.vector()).translation() - T_w_c(ref_kf.x).translation()).norm() >= opt.mono_min_baseline &&
             static_cast<int>(w.f.size()) >= 4 * opt.min_inliers;
    }
    const int with_depth =
        static_cast<int>(std::count_if(w.f.depth.begin(), w.f.depth.end(), [](float d) { return d > 0; }));
    // Not while the landmarks in view say the wheels are wrong: walkers covering most of the view
    // leave too few for vision to place the frame, yet most of the static ones left agree on a pose
    // of their own, away from the wheels', the way a slip makes them; a map restarted there is the
    // slip's. The doubt holds until vision places a frame, or for Estimator.SlipHold after the last
    // such frame (as the wheels run away from the map its landmarks leave the projection search).
    if (w.contradicts_wheels) wheels_doubted_t = w.t;
    const bool doubted = w.t - wheels_doubted_t <= opt.slip_hold;
    return frames_since_kf >= 3 && with_depth >= 4 * opt.min_inliers && !w.after_slip && !doubted;
  }

  // A relocalisation ends a blind stretch where the wheels may have been wrong (they spun while
  // vision could not see it), but only as a slip leaves them: on the way they claimed since the
  // last frame vision placed with them (onTheClaimedWay; not a slip frame, which vision alone
  // placed). (Map lock held.)
  bool onTheWheelsWay(const Eigen::Vector3d& x, double t) {
    std::size_t j = frames.size();
    while (j > 0 && !(frames[j - 1].visual && !frames[j - 1].slip)) --j;
    if (j == 0) return true;
    const FrameRecord& v = frames[j - 1];
    const std::optional<WheelDelta> stretch = wheelDelta(v.t, t);
    if (!stretch || stretch->t0 > v.t + 1e-6) return true;  // no readings over the whole stretch to hold it to
    return onTheClaimedWay(*stretch, (kfPose(v.ref_kf) * v.T_kf_b).inverse() * SE2::fromVector(x));
  }

  // Vision is back after a stretch on the wheels: the map says the pose is C T_wheels (C in the
  // world frame, the wheels' drift while blind). Applied to this frame alone it would be a jump;
  // the frames of the stretch take the fraction s of it (s from 0 at the last visual frame to 1
  // now, along exp(s log C)), so that the trajectory written bends instead of jumping. (Map lock
  // held.)
  void spreadCorrection(const SE2& C, double t) {
    std::size_t first = frames.size();
    while (first > 0 && !frames[first - 1].visual) --first;
    if (first == frames.size() || first == 0) return;
    const double t0 = frames[first - 1].t;
    const Eigen::Vector3d xi = C.log();
    for (std::size_t j = first; j < frames.size(); ++j) {
      FrameRecord& r = frames[j];
      const double s = (r.t - t0) / (t - t0);
      const SE2 T_w_kf = kfPose(r.ref_kf);
      r.T_kf_b = T_w_kf.inverse() * (SE2::exp(s * xi) * (T_w_kf * r.T_kf_b));
    }
  }

  static cv::Mat toGrey(const cv::Mat& image) {
    if (image.channels() == 1) return image;
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }

  void finishFrame(const FrameRecord& record, double t) {
    PoseEstimate pe;
    {
      std::lock_guard<std::mutex> lock(map_mutex);
      frames.push_back(record);
      const SE2 pose = kfPose(record.ref_kf) * record.T_kf_b;
      if (has_last) velocity = last_pose.inverse() * pose;
      last_pose = pose;
      pe = {t, pose, record.visual};
      if (!record.visual && opt.mode != Mode::kWheel) {
        ++counters.wheel_only_frames;
        auto& iv = counters.wheel_only_intervals;
        const double dt = 1.5 / rig.fps;
        if (!iv.empty() && t - iv.back().second <= dt) {
          iv.back().second = t;
        } else {
          iv.emplace_back(t, t);
        }
      }
    }
    last_t = t;
    has_last = true;
    if (callback) callback(pe);
  }

  // Makes a keyframe from the frame's features: tracked points become its observations, close
  // untracked features with depth new points (at least 100 when there are). Returns the points made.
  int createKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                     const cv::Mat& image, int tracked = 0, const std::vector<char>& no_new_point = {}) {
    KeyFrame kf;
    kf.id = next_kf++;
    kf.t = t;
    kf.x = x;
    kf.f = std::move(f);
    kf.tracked = tracked;
    kf.point = point_of.empty() ? std::vector<std::int64_t>(kf.f.size(), -1) : std::move(point_of);
    kf.image = image;  // for the segmenter: the camera's raw image
    for (std::size_t i = 0; i < kf.f.size(); ++i) {
      if (kf.point[i] >= 0) points.at(kf.point[i]).obs[kf.id] = static_cast<int>(i);
    }
    // New points: untracked features with depth (none on walkers: no_new_point), nearest first;
    // every close one, at least 100.
    std::vector<int> cand;
    for (std::size_t i = 0; i < kf.f.size(); ++i) {
      if (kf.point[i] < 0 && kf.f.depth[i] > 0 && (no_new_point.empty() || !no_new_point[i]))
        cand.push_back(static_cast<int>(i));
    }
    std::sort(cand.begin(), cand.end(), [&](int a, int b) { return kf.f.depth[a] < kf.f.depth[b]; });
    const double close = opt.max_depth_baselines * rig.baseline;
    const SE2 T_w_b = SE2::fromVector(x);
    int made = 0;
    for (int i : cand) {
      if (kf.f.depth[i] > close && made >= 100) break;
      const cv::KeyPoint& kp = kf.f.keypoints[i];
      const Eigen::Vector3d P_c = kf.f.depth[i] * rig.camera->unproject(Eigen::Vector2d(kp.pt.x, kp.pt.y));
      const Eigen::Vector3d P_b = rig.T_b_c * P_c;
      const Eigen::Vector2d xy = T_w_b.act(P_b.head<2>());
      newPoint(&kf, i, Eigen::Vector3d(xy.x(), xy.y(), P_b.z()), P_c.norm());
      ++made;
    }
    const std::uint64_t id = kf.id;
    keyframes.emplace(id, std::move(kf));
    KeyFrame& added = keyframes.at(id);
    if (rig.sensor == Sensor::kMono) made += triangulate(&added);
    counters.map_points_created += made;
    if (added.tracked == 0) added.tracked = made;
    frames_since_kf = 0;
    if (segmenter && async) {
      async->submit(added.image, FrameInfo{id, t});
    }
    return made;
  }

  // A new map point seen by feature i of kf at P_w (world), distance m from its camera.
  MapPoint& newPoint(KeyFrame* kf, int i, const Eigen::Vector3d& P_w, double distance) {
    MapPoint p;
    p.id = next_point++;
    p.P = P_w;
    p.descriptor = kf->f.descriptors.row(i).clone();
    p.level = kf->f.keypoints[i].octave;
    p.distance = distance;
    p.obs[kf->id] = i;
    p.visible = p.found = 1;
    p.first_kf = kf->id;
    kf->point[i] = static_cast<std::int64_t>(p.id);
    return points.emplace(p.id, std::move(p)).first->second;
  }

  // Mono: new points from kf's untracked features matched with those of the keyframes before it
  // (kTriangulationNeighbours; two were too few to keep a map through a slow turn) (ORB-SLAM's CreateNewMapPoints, with
  // the keyframes' poses known). Those poses carry the wheels' metric scale (the first two keyframes are placed by the
  // wheels alone), so the map has it too; a turn on the spot (a baseline under Estimator.MonoMinBaseline) triangulates
  // nothing, which is how a pure-rotation start is refused. A pair must lie on the epipolar plane (within 3 sigma of
  // the coarser level, plus 2 mrad for the poses), match (Hamming <= 50, best clearly before second), meet at a
  // parallax >= Estimator.MonoMinParallax in front of both cameras and reproject within the mono chi2 gate in both.
  // Returns the points made. (Map lock held.)
  int triangulate(KeyFrame* kf) {
    const Eigen::Isometry3d T_w_c1 = T_w_c(kf->x);
    const double cos_min = std::cos(opt.mono_min_parallax * M_PI / 180.0);
    std::vector<double> tolerance(opt.levels);  // rad off the epipolar plane, by pyramid level
    for (int l = 0; l < opt.levels; ++l)
      tolerance[l] = 3.0 * opt.sigma_px * std::pow(opt.scale_factor, l) / rig.camera->fx() + 2e-3;
    auto rays = [&](const KeyFrame& k, const Eigen::Isometry3d& T_w_c) {
      std::vector<Eigen::Vector3d> d(k.f.size());
      for (std::size_t i = 0; i < k.f.size(); ++i) {
        const cv::Point2f& pt = k.f.keypoints[i].pt;
        d[i] = (T_w_c.linear() * rig.camera->unproject(Eigen::Vector2d(pt.x, pt.y))).normalized();
      }
      return d;
    };
    const std::vector<Eigen::Vector3d> d1 = rays(*kf, T_w_c1);
    int made = 0;
    auto it = keyframes.find(kf->id);
    for (int n = 0; n < kTriangulationNeighbours && it != keyframes.begin(); ++n) {
      KeyFrame& old = (--it)->second;
      const Eigen::Isometry3d T_w_c2 = T_w_c(old.x);
      const Eigen::Vector3d c1 = T_w_c1.translation(), c2 = T_w_c2.translation(), base = c2 - c1;
      if (base.norm() < opt.mono_min_baseline) continue;
      const std::vector<Eigen::Vector3d> d2 = rays(old, T_w_c2);
      std::vector<int> free_old;
      for (std::size_t j = 0; j < old.f.size(); ++j) {
        if (old.point[j] < 0) free_old.push_back(static_cast<int>(j));
      }
      std::vector<int> best_dist(old.f.size(), 51), best_of(old.f.size(), -1);
      for (std::size_t i = 0; i < kf->f.size(); ++i) {
        if (kf->point[i] >= 0) continue;
        const Eigen::Vector3d normal = d1[i].cross(base).normalized();  // of the epipolar plane
        const int level = kf->f.keypoints[i].octave;
        BestTwo match;
        for (int j : free_old) {
          const int old_level = old.f.keypoints[j].octave;
          if (std::abs(old_level - level) > 1) continue;
          if (std::fabs(normal.dot(d2[j])) > tolerance[std::max(level, old_level)] || d1[i].dot(d2[j]) > cos_min)
            continue;
          match.offer(hammingDistance(kf->f.descriptors.row(i), old.f.descriptors.row(j)), j);
        }
        if (match.index < 0 || match.best > 50 || match.best > 0.8 * match.second) continue;
        if (match.best < best_dist[match.index]) {
          best_dist[match.index] = match.best;
          best_of[match.index] = static_cast<int>(i);
        }
      }
      for (std::size_t j = 0; j < old.f.size(); ++j) {
        const int i = best_of[j];
        if (i < 0 || kf->point[i] >= 0) continue;
        // Midpoint of the closest approach of c1 + a d1 and c2 + b d2.
        const Eigen::Vector3d &u = d1[i], &v = d2[j];
        const double uv = u.dot(v), den = 1.0 - uv * uv;
        if (den < 1e-9) continue;
        const double a = (u.dot(base) - uv * v.dot(base)) / den, b = (uv * u.dot(base) - v.dot(base)) / den;
        if (a <= 0 || b <= 0) continue;
        const Eigen::Vector3d P = 0.5 * (c1 + a * u + c2 + b * v);
        auto fits = [&](const KeyFrame& k, int f) {
          double e2;
          const double sigma = opt.sigma_px * std::pow(opt.scale_factor, k.f.keypoints[f].octave);
          return chi2(false, k.x, P, observation(k.f, f), sigma, &e2) && e2 <= kChi2Mono;
        };
        if (!fits(*kf, i) || !fits(old, static_cast<int>(j))) continue;
        MapPoint& p = newPoint(kf, i, P, (P - c1).norm());
        p.obs[old.id] = static_cast<int>(j);
        old.point[j] = static_cast<std::int64_t>(p.id);
        ++made;
      }
    }
    return made;
  }

  // ================= local mapping =================
  void queueKeyFrame(double kf_t) {
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

  void mappingLoop() {
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

  // Mono tracking no further ahead of local mapping than Estimator.MonoMaxMappingLag of data
  // (threaded; options.h says why mono only).
  void waitForMappingLag(double t) {
    if (opt.deterministic || rig.sensor != Sensor::kMono) return;
    std::unique_lock<std::mutex> lock(queue_mutex);
    if ((pending_keyframe || busy) && t - queued_kf_t > opt.mono_max_mapping_lag) {
      const auto t0 = Clock::now();
      idle_cv.wait(lock, [&] { return !pending_keyframe && !busy; });
      timings.add("wait for mapping", msSince(t0));  // the report's timings: how often, how long
    }
  }

  void waitForMapper() {
    if (opt.deterministic) return;
    std::unique_lock<std::mutex> lock(queue_mutex);
    idle_cv.wait(lock, [&] { return !pending_keyframe && !busy; });
  }

  // Labels of keyframes still in memory that have not had theirs: semantic observations of their
  // points (eqs. 4, 5).
  void applyLabels(bool wait) {
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
      auto t0 = Clock::now();
      if (!async) {
        try {
          seg = segmenter->segment(image, FrameInfo{id, t});
        } catch (const std::exception&) {
        }
      } else {
        seg = wait ? async->waitFor(id, std::chrono::milliseconds(2000)) : async->take(id);
        // Still to come; dropped or failed ones never will: the keyframe is done with (its points
        // trusted, as unlabelled ones are).
        if (!seg && !wait && async->pending(id)) continue;
      }
      if (!async) timings.add("segmentation", msSince(t0));
      std::lock_guard<std::mutex> lock(map_mutex);
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

  void mapKeyFrame() {
    auto t0 = Clock::now();
    applyLabels(opt.deterministic);
    cullPoints();
    localBundleAdjustment();
    dropOldKeyFrames();
    timings.add("local mapping", msSince(t0));
  }

  // Points found in fewer than a quarter of the frames that should have seen them, or seen by
  // one keyframe only two keyframes after their birth: gone (ORB-SLAM's culling).
  void cullPoints() {
    std::lock_guard<std::mutex> lock(map_mutex);
    if (keyframes.empty()) return;
    const std::uint64_t newest = std::prev(keyframes.end())->first;
    for (auto it = points.begin(); it != points.end();) {
      const MapPoint& p = it->second;
      const bool rarely_found = p.visible >= 8 && p.found < 0.25 * p.visible;
      const bool lonely = newest >= p.first_kf + 3 && p.obs.size() <= 1 && rig.sensor == Sensor::kMono;
      if (rarely_found || lonely || p.obs.empty()) {
        if (reliability.alpha(it->first) == -BarronKernel::kInfinity) ++counters.map_points_rejected;
        eraseObservations(p);
        reliability.forget(it->first);
        it = points.erase(it);
      } else {
        ++it;
      }
    }
  }

  void eraseObservations(const MapPoint& p) {
    for (const auto& [kf_id, feature] : p.obs) {
      auto kf = keyframes.find(kf_id);
      if (kf != keyframes.end()) kf->second.point[feature] = -1;
    }
  }

  // The window's problem under the map lock: the last Estimator.Window keyframes free, the one
  // before them fixed (it carries the gauge and the wheel edge into the window; at the start, the
  // first keyframe), the points they see that the kernel does not reject, and every keyframe in
  // memory that sees those points, fixed. ids: the keyframes' and points' ids, in the problem's
  // order; features: per observation, the keyframe's feature. (Map lock held.)
  WindowProblem windowProblem(std::vector<std::uint64_t>* kf_ids, std::vector<std::uint64_t>* point_ids,
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

  // Wheel edges between keyframes consecutive in time, one end at least free: Huber across a slip
  // tracking caught; across a spin (Estimator.SlipHoldMinFrames frames or more where the robot
  // about stood while the wheels went on) out of the first round, stereo and RGB-D only (mono's
  // window takes its scale from them; docs/decisions/0003).
  void addWheelEdges(WindowProblem* pb, const std::vector<std::uint64_t>& kf_ids) {
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
                            rig.sensor != Sensor::kMono && slips.spins >= opt.slip_hold_min_frames});
    }
  }

  WindowOptions windowOptions() const {
    WindowOptions wo;
    wo.huber = opt.kernel == KernelChoice::kHuber;
    wo.barron_scale = opt.barron_scale;
    wo.out_of_plane = opt.out_of_plane;
    wo.min_views = rig.sensor == Sensor::kMono ? 2 : 1;  // a mono point needs two views for its depth
    wo.outliers_leave = true;
    wo.drop_slipping_wheel_edges = true;
    wo.slipped_wheel_chi2 = kChi2Stereo;
    wo.calibrate = opt.mode == Mode::kVw && opt.calibrate;
    // Mono has no metric but the wheels': scaling the window's map and the wheels' distance scale
    // together changes no residual (left free, it drifted to 0.976-0.994 over the mono suite).
    wo.hold_distance_scale = rig.sensor == Sensor::kMono;
    wo.calibration_sigma = opt.calibration_sigma;
    wo.calibration_step = opt.calibration_step;
    wo.calibration_period = opt.calibration_period;
    return wo;
  }

  // Local BA over the window (rvwo::solveWindow), solved without the map lock, written back under
  // it: poses, points, outlier observations erased, each point's RMS error into its reliability
  // (eq. 6), the wheels' calibration if the window taught it.
  void localBundleAdjustment() {
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
      calibration.refined(sol.calibration, newestTime(pb));
    }
    writeBack(pb, sol, kf_ids, point_ids, features);
  }

  static double newestTime(const WindowProblem& pb) {
    double t = -1e300;
    for (const WindowKeyFrame& k : pb.keyframes) t = std::max(t, k.t);
    return t;
  }

  // (Map lock held.)
  void writeBack(const WindowProblem& pb, const WindowSolution& sol, const std::vector<std::uint64_t>& kf_ids,
                 const std::vector<std::uint64_t>& point_ids, const std::vector<int>& features) {
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

  // Keyframes beyond keep_keyframes leave memory: their poses are final, their points forgotten
  // when no keyframe in memory sees them, the wheel readings before them dropped.
  void dropOldKeyFrames() {
    std::lock_guard<std::mutex> lock(map_mutex);
    while (keyframes.size() > static_cast<std::size_t>(opt.keep_keyframes)) {
      auto it = keyframes.begin();
      const KeyFrame& kf = it->second;
      final_pose[kf.id] = SE2::fromVector(kf.x);
      for (std::size_t i = 0; i < kf.f.size(); ++i) {
        if (kf.point[i] < 0) continue;
        auto p = points.find(kf.point[i]);
        if (p == points.end()) continue;
        p->second.obs.erase(kf.id);
        if (p->second.obs.empty()) {
          if (reliability.alpha(p->first) == -BarronKernel::kInfinity) ++counters.map_points_rejected;
          reliability.forget(p->first);
          points.erase(p);
        }
      }
      keyframes.erase(it);
    }
    if (!keyframes.empty()) {
      std::lock_guard<std::mutex> slock(slip_mutex);
      while (!slip_marks.empty() && slip_marks.front().t < keyframes.begin()->second.t) slip_marks.pop_front();
    }
    if (!keyframes.empty()) {
      std::lock_guard<std::mutex> olock(odometry_mutex);
      if (!odometry.empty()) odometry.dropBefore(keyframes.begin()->second.t - 1.0);
    }
  }

  // ================= input =================
  void drain(bool all) {
    // A frame waits until the odometry has passed its time (so its prediction has the readings
    // that straddle it), for at most a second of frames.
    // With a front end running ahead, a frame is also held until the next one has come, so that
    // the next one's features are made while this one is tracked (a frame's latency more).
    const std::size_t lookahead = front_end_queue ? 1 : 0;
    while (pending.size() > (all ? 0 : lookahead)) {
      const double t = pending.front().in.timestamp;
      bool ready = all || opt.mode == Mode::kVo || pending.size() > static_cast<std::size_t>(rig.fps) + 1;
      if (!ready) {
        std::lock_guard<std::mutex> lock(odometry_mutex);
        ready = !odometry.empty() && odometry.lastTime() >= t;
      }
      if (!ready) break;
      PendingFrame next = std::move(pending.front());
      pending.pop_front();
      processFrame(next.in, std::move(next.front_end));
    }
  }
};

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
  r.slip_frames = impl_->slip_frames;
  r.wheel_edge_outliers = impl_->wheel_outliers;
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
