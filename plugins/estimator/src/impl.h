// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The estimator's inside, shared by its files by role: front_end.cc (features, stereo matching or
// depth), map.cc (keyframes, points, what is trusted), tracker.cc (predict, match, solve, decide,
// relocalise, keyframe), mapper.cc (the local-mapping thread: labels, culling, the window BA through
// rvwo::solveWindow), estimator.cc (the public interface). Private to the library.
#pragma once

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

#include "rvwo/ceres/costs.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/estimator/estimator.h"
#include "rvwo/estimator/features.h"
#include "rvwo/kernels/barron.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/semantics/label_lookup.h"
#include "rvwo/tracking/frame_arbiter.h"
#include "rvwo/tracking/planar_pose.h"
#include "rvwo/tracking/wheel_checks.h"
#include "rvwo/tracking/window.h"

namespace rvwo::estimator {

using Clock = std::chrono::steady_clock;
inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

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
  // matches or depth, and the image the segmenter will see.
  struct FrontEnd {
    Features f;
    cv::Mat raw_image;  // as the camera gave it, colour kept for a network (labels are rectified after)
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
  std::size_t slip_frames = 0;                 // frames where vision overruled the wheels
  std::atomic<std::size_t> wheel_outliers{0};  // wheel edges local BA found wrong
  std::mutex slip_mutex;
  struct SlipMark {
    double t;
    bool spin;  // the robot about stood while the wheels went on (slipIsSpin)
  };
  std::deque<SlipMark> slip_marks;  // of those frames, since the oldest keyframe in memory
  // The wheels against vision, frame by frame (the slip, the stall, the wheel gate, the hold, the
  // relocalisation's belief): tracking's.
  FrameArbiter arbiter;
  static ArbiterOptions arbiterOptions(const Rig& r, const EstimatorOptions& o);

  struct SlipCount {
    int frames = 0, spins = 0;
  };
  SlipCount slipsBetween(double t0, double t1);
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
        segmenter(o.semantics ? std::move(seg) : nullptr),
        arbiter(arbiterOptions(r, o)) {
    if (r.sensor != Sensor::kMono) stereo_edge.emplace(*r.camera, r.T_b_c, r.bf());
    if (segmenter && !opt.deterministic) async = std::make_unique<AsyncSegmenter>(segmenter, 4, 256);
    dynamic_labels = opt.priors.dynamicLabels();
    if (!opt.deterministic) mapper = std::thread([this] { mappingLoop(); });
    if (!opt.deterministic && opt.mode != Mode::kWheel) front_end_queue = std::make_unique<TaskQueue>();
  }

  ~Impl() { stopMapper(); }

  void stopMapper();

  // ================= helpers =================
  SE2 kfPose(std::uint64_t id) const;

  double kernelAlpha(std::uint64_t point) const;

  // A landmark no label has called dynamic (P_s below Tracking.TrustedMaxPs),
  // and, with labels coming from the segmentation thread, not one whose keyframe still waits for
  // its labels: a keyframe's new points are the closest features, often a walker's, and counted
  // as trusted for the frame or two until its labels came they placed frames and made vision
  // flicker (threaded RGB-D dynamic: trusted matches 176, 26, 164, 17 in consecutive frames).
  // (Map lock held.)
  bool isTrusted(std::uint64_t point) const;
  std::vector<char> trustedOf(const std::vector<Match>& matches) const;

  // A landmark the adaptive (or a fixed alpha = -inf) kernel rejects: its edges leave the problem.
  bool rejected(double alpha) const { return opt.kernel != KernelChoice::kHuber && alpha == -BarronKernel::kInfinity; }

  // Whitened chi2 of observation z = (u, v, u_R) at x (u_R unused unless stereo), with the
  // information at x (rvwo::whitenedChi2); false when the point does not project.
  bool chi2(bool stereo, const Eigen::Vector3d& x, const Eigen::Vector3d& P, const Eigen::Vector3d& z, double sigma,
            double* out) const;
  // The camera's pose in the world at the robot pose x = (x, y, theta).
  Eigen::Isometry3d T_w_c(const Eigen::Vector3d& x) const { return SE2::fromVector(x).isometry3() * rig.T_b_c; }

  // Predicted (u, v, u_R) of P_w from x (mono: u_R = -1); false when it does not project.
  bool predict(const Eigen::Vector3d& x, const Eigen::Vector3d& P_w, Eigen::Vector3d* h) const;
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
  std::vector<Match> searchByProjection(const Features& f, const Eigen::Vector3d& x, double radius_scale);

  // Relocalisation against the map in memory (stereo and RGB-D), when the projection search
  // finds nothing: after a blind stretch the wheels' prediction may be far off (a slip while a
  // walker covered the view left it 0.6 rad off, and the map was started anew from there). Each
  // feature with depth is matched by descriptor with the trusted landmarks (Hamming <= 50, clearly
  // better than the second best, at the same height within 0.2 m: the robot stays on its floor);
  // two pairs fix an SE(2) pose from their ground-plane positions (RANSAC, a fixed seed); the best
  // pose, if 3 x Tracking.MinInliers pairs agree with it, seeds the projection search and the pose
  // optimisation. (Map lock held.)
  std::optional<Eigen::Vector3d> relocalise(const Features& f);

  // The frame's matches as the pose solver takes them, each with its landmark's kernel. (Map lock
  // held.)
  std::vector<PoseObservation> poseObservations(const Features& f, const std::vector<Match>& matches) const;
  const PlanarPoseOptions& poseOptions() const { return arbiter.options().pose; }

  // Pose-only optimisation on SE(2): iteratively reweighted Gauss-Newton with each landmark's
  // kernel, in rounds (ORB-SLAM's): after each, residuals beyond the chi2 gate are outliers for
  // the next. prior: the wheel edge from the previous frame (fixed) to this one.
  int optimisePose(const Features& f, const std::vector<Match>& matches, const std::optional<WheelEdge>& prior,
                   const Eigen::Vector3d& x_prev, Eigen::Vector3d* x, std::vector<char>* inlier,
                   std::vector<double>* errors);

  // The wheels' motion between t0 and t1, clipped to the readings there are; none in vo mode or
  // without odometry. (Tracking writes the wheel buffer, mapping reads it: under its lock.)
  // Integrated with the calibration as estimated so far.
  std::optional<WheelDelta> wheelDelta(double t0, double t1);

  FrontEnd frontEnd(const FrameInput& in);

  // One frame's tracking as it goes through the steps of processFrame.
  struct FrameWork {
    double t = 0;
    std::optional<WheelDelta> delta;  // the wheels since the last frame (none: vo, or no readings)
    SE2 predicted;                    // where they (or the motion model) put the robot
    Features f;
    cv::Mat raw_image;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();  // the pose being solved
    std::vector<Match> matches;
    std::vector<char> inlier, trusted;  // per match
    std::vector<double> errors;         // per match: whitened error
    int inliers = 0;
    bool strained = false;  // vision strains the wheel edge from the last frame
    bool visual = false;
    bool after_slip = false, wheels_doubted = false;  // FrameOutcome's
    int countTrusted(const std::vector<char>& in) const { return rvwo::countTrusted(in, trusted); }
  };

  // The frame's pipeline: predict from the wheels, extract features (made ahead in the front
  // end's thread), track the local map (match, solve, decide wheels or vision), relocalise when
  // still blind, hold after a slip, then keep the pose and decide on a keyframe.
  void processFrame(const FrameInput& in, std::future<FrontEnd> front_end = {});

  // The pose the wheels predict from the last frame's (refreshed from its reference keyframe,
  // which local BA may have moved), or without them the motion model's.
  void predictFrame(FrameWork* w);

  // Matches to the local map, then the frame's pose and the wheels against vision (the arbiter).
  // (Map lock held.)
  void trackLocalMap(FrameWork* w);

  // The wheels against vision for this frame (rvwo::FrameArbiter): the pose solved with the wheel
  // edge, a slip (vision alone overrules them), a stall (mono), the wheel gate (docs/decisions/0002).
  FrameEvidence frameEvidence(const FrameWork& w);
  // A slip frame: counted and marked for local BA (a spin's wheel edge sits out its first round).
  void recordSlip(double t, bool spin);
  void markSlip(double t, bool spin);

  // Still blind after a stretch on the wheels: their prediction may be too far off for the
  // projection search, the map in memory may still be in view. Only trusted landmarks place the
  // frame (walkers' landmarks a label has seen, still inliers under their kernel, would pull the
  // pose along); the arbiter says whether the result is believed. (Map lock held.)
  void relocaliseBlindFrame(FrameWork* w);

  // Blind right after a slip, the wheels are the last to trust: the arbiter holds the pose where
  // vision left it (for at most Tracking.SlipHold), and its frames count as the spin they hold
  // (docs/decisions/0009). It also says whether the landmarks in view doubt the wheels.
  void settleFrame(FrameWork* w);

  // The frame's pose (vision's, held, or the wheels'), its landmarks' reliabilities (eq. 6), and a
  // keyframe if one is due. Returns whether one was made. (Map lock held.)
  bool keepFrame(FrameWork* w, FrameRecord* record);

  // ORB-SLAM's keyframe rules with RVWO's exceptions (docs/estimator.md, rule 11). Visual: every
  // Estimator.KeyFrameMaxFrames frames, when the reference keyframe's points are less than
  // Estimator.KeyFrameRatio tracked, or for close untracked features, but not in a slip nor while
  // vision strains the wheel edge (a keyframe made at a pose the wheels pulled along moves the map
  // with them). Blind: a keyframe at the wheels' pose restarts the map once there is texture,
  // unless it holds after a slip or the landmarks in view doubt the wheels. (Map lock held.)
  bool keyFrameDue(const FrameWork& w, const SE2& T_w_b, const std::vector<std::int64_t>& point_of,
                   const std::vector<char>& on_walker, const KeyFrame& ref_kf);

  // A relocalisation ends a blind stretch where the wheels may have been wrong (they spun while
  // vision could not see it), but only as a slip leaves them: on the way they claimed since the
  // last frame vision placed with them (onTheClaimedWay; not a slip frame, which vision alone
  // placed). (Map lock held.)
  bool onTheWheelsWay(const Eigen::Vector3d& x, double t);

  // Vision is back after a stretch on the wheels: the map says the pose is C T_wheels (C in the
  // world frame, the wheels' drift while blind). Applied to this frame alone it would be a jump;
  // the frames of the stretch take the fraction s of it (s from 0 at the last visual frame to 1
  // now, along exp(s log C)), so that the trajectory written bends instead of jumping. (Map lock
  // held.)
  void spreadCorrection(const SE2& C, double t);

  static cv::Mat toGrey(const cv::Mat& image);

  void finishFrame(const FrameRecord& record, double t);

  // Makes a keyframe from the frame's features: tracked points become its observations, close
  // untracked features with depth new points (at least 100 when there are). Returns the points made.
  int createKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                     const cv::Mat& image, int tracked = 0, const std::vector<char>& no_new_point = {});

  // A new map point seen by feature i of kf at P_w (world), distance m from its camera.
  MapPoint& newPoint(KeyFrame* kf, int i, const Eigen::Vector3d& P_w, double distance);

  // Mono: new points from kf's untracked features matched with those of the keyframes before it
  // (kTriangulationNeighbours; two were too few to keep a map through a slow turn) (ORB-SLAM's CreateNewMapPoints, with
  // the keyframes' poses known). Those poses carry the wheels' metric scale (the first two keyframes are placed by the
  // wheels alone), so the map has it too; a turn on the spot (a baseline under Estimator.MonoMinBaseline) triangulates
  // nothing, which is how a pure-rotation start is refused. A pair must lie on the epipolar plane (within 3 sigma of
  // the coarser level, plus 2 mrad for the poses), match (Hamming <= 50, best clearly before second), meet at a
  // parallax >= Estimator.MonoMinParallax in front of both cameras and reproject within the mono chi2 gate in both.
  // Returns the points made. (Map lock held.)
  int triangulate(KeyFrame* kf);

  // ================= local mapping =================
  void queueKeyFrame(double kf_t);

  void mappingLoop();

  // Mono tracking no further ahead of local mapping than Estimator.MonoMaxMappingLag of data
  // (threaded; options.h says why mono only).
  void waitForMappingLag(double t);

  void waitForMapper();

  // Labels of keyframes still in memory that have not had theirs: semantic observations of their
  // points (eqs. 4, 5).
  void applyLabels(bool wait);

  void mapKeyFrame();

  // Points found in fewer than a quarter of the frames that should have seen them, or seen by
  // one keyframe only two keyframes after their birth: gone (ORB-SLAM's culling).
  void cullPoints();

  void eraseObservations(const MapPoint& p);

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
  void addWheelEdges(WindowProblem* pb, const std::vector<std::uint64_t>& kf_ids);

  WindowOptions windowOptions() const;

  // Local BA over the window (rvwo::solveWindow), solved without the map lock, written back under
  // it: poses, points, outlier observations erased, each point's RMS error into its reliability
  // (eq. 6), the wheels' calibration if the window taught it.
  void localBundleAdjustment();

  // (Map lock held.)
  void writeBack(const WindowProblem& pb, const WindowSolution& sol, const std::vector<std::uint64_t>& kf_ids,
                 const std::vector<std::uint64_t>& point_ids, const std::vector<int>& features);

  // Keyframes beyond keep_keyframes leave memory: their poses are final, their points forgotten
  // when no keyframe in memory sees them, the wheel readings before them dropped.
  void dropOldKeyFrames();

  // ================= input =================
  void drain(bool all);
};

}  // namespace rvwo::estimator
