// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// Wheel odometry for ORB-SLAM3's tracking, reached from the calls that patches/orbslam3/ inserts.
// ORB-SLAM3 gets the readings since the previous frame with each image (System::TrackStereo /
// TrackRGBD / TrackMonocular overloads, as its IMU path gets IMU points), and this class
//   - predicts the camera pose of the new frame from the previous one and the wheels
//     (replacing the constant-velocity model):
//
//       T_cj_w = T_c_b * T_bj_bi * T_b_c * T_ci_w,   T_bi_bj = wheel delta on SE(2) (eq. 11)
//
//   - carries the pose on the wheels while vision cannot place the frame (lens covered, no
//     texture), so that tracking is never lost and the map resumes from there;
//   - asks for a keyframe while it carries a stereo or RGB-D frame that has features again, so
//     that new map points restart tracking where the old map is out of sight;
//   - optimises a stereo or RGB-D frame's pose on SE(2) (optimisePose, in place of ORB-SLAM3's
//     6-DoF PoseOptimization): SE(2)-XYZ edges with out-of-plane noise (eqs. 8 to 10), each map
//     point under its adaptive Barron kernel (eqs. 6, 7), and the wheel edge from the previous
//     frame (eq. 14), unless the wheels slipped;
//   - optimises the local map of a stereo or RGB-D keyframe (optimiseLocalMap, in place of
//     ORB-SLAM3's 6-DoF LocalBundleAdjustment): keyframe poses on SE(2), map points in 3-D,
//     SE(2)-XYZ edges under each point's adaptive kernel and wheel edges between keyframes
//     consecutive in time (eqs. 6 to 14); the same over the whole map after a loop
//     (optimiseLocalMap via optimiseGlobalMap), and loop closing's essential graph on SE(2) with
//     wheel edges beside vision's relative poses (optimiseEssentialGraph);
//   - sends keyframes to a segmenter in a thread of its own, and their labels to the reliability
//     of the map points their keypoints see (eqs. 4, 5): a walker's points lose their weight in
//     tracking (alpha towards -inf) before they have moved.
//
// This header is included by ORB-SLAM3's Tracking.h, which upstream compiles as C++11: it uses
// nothing newer and hides the C++17 core behind a pointer.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rvwo/tracking/options.h"

namespace cv {
class Mat;
}

namespace rvwo {
class Segmenter;

namespace orbslam3 {

// One odometry reading as the robot's driver gives it, stamped on the camera's clock (s).
struct WheelReading {
  enum Kind { kWheelAngles, kWheelSpeeds, kPose };
  double t;
  Kind kind;
  double a, b, c;  // kWheelAngles: cumulative left, right wheel angles [rad];
                   // kWheelSpeeds: left, right wheel speeds [rad/s];
                   // kPose: x [m], y [m], theta [rad] of the odometry frame in the odometry's world.
  static WheelReading angles(double t, double left, double right) { return {t, kWheelAngles, left, right, 0}; }
  static WheelReading speeds(double t, double left, double right) { return {t, kWheelSpeeds, left, right, 0}; }
  static WheelReading pose(double t, double x, double y, double theta) { return {t, kPose, x, y, theta}; }
};

// TrackingOptions with the plugin's defaults (docs/decisions/0011).
inline TrackingOptions orbslam3Tracking() {
  TrackingOptions t;
  t.min_inliers = 30;
  return t;
}

struct WheelInputParams {
  // false: no wheels [Odometry.Input: "none"]. RVWO's vision alone in ORB-SLAM3's 6-DoF tracking:
  // optimisePose solves the frame in 6-DoF (rvwo/tracking/spatial_pose.h) with each map point's
  // labels and adaptive kernel (eqs. 4 to 7); no reading is taken, nothing is planar, and local
  // mapping, loop closing and keyframes stay ORB-SLAM3's own (the paper's Table I, TUM RGB-D).
  bool wheels = true;
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();  // the (left) camera in the body frame [Camera.T_b_c]
  Eigen::Isometry3d T_b_o = Eigen::Isometry3d::Identity();  // odometry frame in the body frame [Odometry.T_b_o]
  double radius_left = 0.1, radius_right = 0.1;             // m [Odometry.WheelRadiusLeft/Right]
  double track = 0.5;                                       // m [Odometry.Track]
  bool map_from_depth = true;          // stereo or RGB-D: a keyframe alone makes map points [Sensor]
  int min_features = 500;              // features a frame carried on the wheels needs for a keyframe
                                       // (ORB-SLAM3's own bar for starting a stereo map)
  int keyframe_every = 5;              // frames between keyframes while on the wheels (stereo, RGB-D)
  double mono_keyframe_travel = 0.15;  // m the wheels travel between keyframes while on them (mono)
  bool aligned_pyramid = true;         // ORB-SLAM3's image pyramid resampled where its keypoints' coordinates
                                       // put each level (rvwo/orbslam3/pyramid.h); upstream's misplaces
                                       // coarse keypoints and shortened its stereo map 0.15 %, and the
                                       // wheels' distance scale learnt that [ORBextractor.AlignedPyramid: 1 | 0]
  // ---- pose optimisation on SE(2) (stereo and RGB-D; mono keeps ORB-SLAM3's own)
  bool planar = true;  // optimisePose answers [Tracking.Planar: 1 | 0]
  bool huber = false;  // Huber (ORB-SLAM3's kernel) instead of the adaptive Barron kernel
                       // [Tracking.Kernel: adaptive | huber]
  // The tracking core's policy [Tracking.*: rvwo/tracking/options.h], with ORB-SLAM3's bar for a
  // tracked frame (30 inliers) for vision to place one.
  TrackingOptions tracking = orbslam3Tracking();
  bool local_map = true;  // optimiseLocalMap answers (with planar) [LocalMapping.Planar: 1 | 0]
  bool calibrate = true;  // the local map refines the odometry's calibration (distance
                          // scale, turn scale, curvature), applied to every wheel edge
                          // [Odometry.Calibrate: 1 | 0]
  Eigen::Vector3d calibration_sigma = Eigen::Vector3d(0.05, 0.05, 0.2);     // prior around 0 (1, 1, rad/m),
                                                                            // counted once, then a bound
  Eigen::Vector3d calibration_step = Eigen::Vector3d(0.003, 0.003, 0.005);  // around the last, per local map
                                                                            // calibration_period after the last
                                                                            // (ceres_adapters::wheelCalibrationStep)
  // When constant, its slow drift per calibration_period on top of what is known.
  Eigen::Vector3d calibration_drift = Eigen::Vector3d(3e-4, 3e-4, 5e-4);
  double calibration_period = 0.5;  // s
  // c a constant the wheels learn better as they run (with calibration_drift), or a walk of
  // calibration_step that follows each local map (WheelCalibrationEstimate::counting)
  // [Odometry.CalibrationConstant: 1 | 0]
  bool calibration_constant = false;
  // The distance scale among what is refined; otherwise held at the settings' radii, as for mono,
  // where it is unobservable (the map's scale is the wheels') [Odometry.CalibrateDistance: 1 | 0;
  // mono 0]
  bool calibrate_distance = true;
  double max_wheel_span = 5.0;  // s: the longest stretch between keyframes a wheel edge of the
                                // local map spans (calibration errors grow beyond its covariance)
                                // [LocalMapping.MaxWheelSpan]
  int spin_min_frames = 3;      // frames where vision saw the robot stand while the wheels went on that make
                                // a spin: a wheel edge across one sits out the local map's first round
                                // [LocalMapping.SpinMinFrames] (the estimator's Tracking.SlipHoldMinFrames)
  // ---- a monocular map's first two keyframes against the wheels (monocularScale)
  double init_min_travel = 0.05;  // m: the wheels' travel between them below which vision's motion
                                  // is taken for a rotation alone [Initializer.MinTravel]
  double init_max_turn = 0.035;   // rad: how far vision's turn (tilt included) may be off the
                                  // wheels', beyond 3 sigma of theirs [Initializer.MaxTurnError]
  double init_max_path = 0.2;     // the body's path vision implies, off the wheels' by at most this
                                  // fraction of its length, beyond 3 sigma [Initializer.MaxPathError]
  // ---- the essential graph after a loop (loop closing's pose graph) on SE(2)
  bool essential_graph = true;     // optimiseEssentialGraph answers (with local_map) [LoopClosing.Planar: 1 | 0]
  double graph_sigma_xy = 0.005;   // m: vision's relative pose between two keyframes of the essential
                                   // graph, each axis [LoopClosing.SigmaXY]
  double graph_sigma_yaw = 0.002;  // rad: its heading [LoopClosing.SigmaYaw]
  int label_dilation_px = 8;       // dynamic classes' masks widened by this much [Segmentation.LabelDilation]
  // Segmentation.Model: an ONNX network for the keyframes' labels (a path relative to the settings
  // file; its classes: the label set); unset: the network RVWO ships (voc21); "none": no network
  // unless setSegmenter gives one.
  // The label set and its priors: Semantics.LabelSet, Semantics.Prior.<class> (voc21 by default).
  // Noise densities of the odometry [Odometry.Noise*] and the reliability model [Reliability.*]
  // are read from the settings into the plugin's own (C++17) types.
};

// One match of a frame to a map point, as ORB-SLAM3's Frame holds it.
struct PoseMatch {
  Eigen::Vector3d P_w;  // the map point in ORB-SLAM3's world [m]
  double u, v;          // undistorted keypoint [px]
  double u_right;       // right-image column [px]; < 0: none (a monocular observation)
  int level;            // pyramid level of the keypoint
  unsigned long id;     // the map point's id (its reliability)
};

// A frame's pose problem: its matches, its prediction, and the frame before it.
struct PoseProblem {
  double t;
  Eigen::Isometry3d T_c_w;  // the prediction
  bool has_previous;        // the previous frame has a pose: the wheel edge ties to it
  double t_previous;
  Eigen::Isometry3d T_cp_w;
  double fx, fy, cx, cy;  // rectified pinhole intrinsics [px]
  double bf;              // stereo baseline times fx [px m]
  double scale_factor;    // between pyramid levels (ORB-SLAM3's 1.2)
  std::vector<PoseMatch> matches;
};

// A keyframe's keypoint (in the image as given, where its labels are) and the map point it sees.
struct KeyFrameFeature {
  float u, v;
  unsigned long id;
};

// ---- A keyframe's local map (ORB-SLAM3's local bundle adjustment problem)
struct MapKeyFrame {
  unsigned long id;
  double t;
  Eigen::Isometry3d T_c_w;
  bool fixed;             // held (ORB-SLAM3's: the map's first, and those seeing local points only)
  double fx, fy, cx, cy;  // rectified pinhole intrinsics [px]
  double bf;              // stereo baseline times fx [px m]
};
struct MapPointEstimate {
  unsigned long id;
  Eigen::Vector3d P_w;  // in ORB-SLAM3's world [m]
};
struct MapObservation {
  int keyframe, point;  // indices into LocalMapProblem's keyframes, points
  double u, v;          // undistorted keypoint [px]
  double u_right;       // right-image column [px]; < 0: none
  int level;            // pyramid level
};
struct LocalMapProblem {
  std::vector<MapKeyFrame> keyframes;
  std::vector<MapPointEstimate> points;
  std::vector<MapObservation> observations;
  double scale_factor;  // between pyramid levels
};
struct LocalMapSolution {
  std::vector<Eigen::Isometry3d> T_c_w;  // per keyframe (fixed ones as given)
  std::vector<char> placed;              // per keyframe: free and in the problem (seen, or on a wheel edge)
  std::vector<Eigen::Vector3d> P_w;      // per point
  std::vector<char> solved;              // per point: in the problem (not rejected, seen)
  std::vector<char> outlier;             // per observation: beyond the chi2 gate, or behind the camera
  int wheel_edges;                       // between keyframes
  bool calibrated;                       // the odometry's calibration learnt from this local map
};

// ---- The essential graph after a loop (ORB-SLAM3's OptimizeEssentialGraph problem)
struct GraphKeyFrame {
  unsigned long id;
  double t;
  Eigen::Isometry3d T_c_w;  // the start: corrected by the loop near it, as tracked elsewhere
  bool fixed;               // held (the map's first)
};
struct GraphEdge {
  int i, j;                   // indices into EssentialGraph's keyframes
  Eigen::Isometry3d T_cj_ci;  // vision's relative pose (spanning tree, covisibility, loops)
};
struct EssentialGraph {
  std::vector<GraphKeyFrame> keyframes;
  std::vector<GraphEdge> edges;
};
struct EssentialGraphSolution {
  std::vector<Eigen::Isometry3d> T_c_w;  // per keyframe (fixed, or on no edge: as given)
  int wheel_edges;                       // between keyframes consecutive in time
};

struct PoseSolution {
  Eigen::Isometry3d T_c_w;
  std::vector<char> outlier;  // per match
  int inliers;
  bool slip;  // the wheels disagreed with vision (slipped): vision alone placed the frame
};

class WheelInput {
 public:
  WheelInput();  // inactive: ORB-SLAM3 behaves as upstream
  ~WheelInput();
  WheelInput(const WheelInput&) = delete;
  WheelInput& operator=(const WheelInput&) = delete;

  // Active with these parameters (noise from the settings' defaults).
  void configure(const WheelInputParams& params);
  // Reads RVWO's keys from ORB-SLAM3's settings YAML: active when it has Camera.T_b_c, inactive
  // (upstream behaviour) when it has no Odometry.* and no Camera.T_b_c key. Throws
  // std::invalid_argument naming the file and key of a bad or missing value.
  void configure(const std::string& settings_path);
  bool active() const;
  // Whether ORB-SLAM3's extractors resample their pyramids with resamplePyramidLevel: active and
  // WheelInputParams::aligned_pyramid. Inactive, ORB-SLAM3's pyramid stays upstream's.
  bool alignedPyramid() const;

  // Readings since the previous frame, in time order. Throws std::invalid_argument on NaN, a
  // time going back, or a kind other than the stream's first.
  void add(const std::vector<WheelReading>& readings);
  // Whether the readings cover [ti, tj], so that predict() can answer.
  bool covers(double ti, double tj) const;
  // T_cj_w from T_ci_w and the wheels between ti and tj; std::out_of_range unless covers().
  Eigen::Isometry3d predict(const Eigen::Isometry3d& T_ci_w, double ti, double tj) const;

  // After tracking a frame: whether vision placed it (else the wheels did), and its features.
  void frameTracked(double t, bool visual, int features);
  // Whether the frame just tracked should become a keyframe to restart the map from the wheels.
  bool keyFrameNeeded() const;
  // Whether the frame just tracked becomes a keyframe, given ORB-SLAM3's wish (NeedNewKeyFrame,
  // from the inliers it counted last): its wish, unless the wheels carried this frame with too
  // few features for map points; or keyFrameNeeded(). A keyframe that sees nothing has no parent
  // in the spanning tree, so no loop correction or global BA ever moves it, nor the frames on it.
  bool keyFrameWanted(bool orbslam3_needs) const;
  // Whether local mapping triangulates a new keyframe's points against the keyframes before it in
  // time too, as ORB-SLAM3 does with an IMU (mono in metres): a keyframe the wheels placed sees no
  // map point yet, so it has no covisible keyframe to triangulate with.
  bool triangulatesInTime() const;
  std::size_t wheelOnlyFrames() const;

  // The factor that puts a monocular two-view map in metres (its keyframes at t0 and t1, T_c1_w's
  // translation and the points in the map's own unit): the one that makes the body's motion the
  // map implies (through T_b_c) closest to the wheels'. 0: the map disagrees with the wheels (its
  // turn or tilt, or its direction of travel), or the wheels barely moved (vision's translation
  // is then an artefact of a rotation): the initialisation is to be rejected. -1: no answer
  // (inactive, not monocular, the readings do not cover [t0, t1]). A map put in metres has the
  // wheels' scale: its poses are optimised on SE(2) as a stereo map's (optimisesPoses) until the
  // next map's answer.
  double monocularScale(double t0, double t1, const Eigen::Isometry3d& T_c0_w, const Eigen::Isometry3d& T_c1_w);
  // [first, last] frame time of each stretch on the wheels.
  std::vector<std::pair<double, double> > wheelOnlyIntervals() const;

  // Whether optimisePose answers (active, planar, stereo or RGB-D, or mono in metres; without
  // wheels, any).
  bool optimisesPoses() const;
  // The pose of a frame on SE(2) (without wheels: in 6-DoF): false (and nothing written) when
  // optimisesPoses() is false or the problem has fewer than 3 matches, for ORB-SLAM3's own
  // PoseOptimization to run instead.
  bool optimisePose(const PoseProblem& problem, PoseSolution* solution);
  // Whether optimiseLocalMap answers (optimisesPoses() and LocalMapping.Planar).
  bool optimisesLocalMaps() const;
  // The local map on SE(2). Safe to call from ORB-SLAM3's local mapping thread while tracking
  // calls the rest. stop: ORB-SLAM3's abort flag, read between iterations (the state reached is
  // kept). False (nothing written) when optimisesLocalMaps() is false. Wheel edges come from the
  // readings kept (the last 20 s or more) or, beyond them, from each keyframe's delta from the
  // one before it in time, taken when a problem (its local map) first had it: the global BA and
  // the essential graph after a loop have them over the whole map.
  bool optimiseLocalMap(const LocalMapProblem& problem, LocalMapSolution* solution, const bool* stop = 0);
  // Whether optimiseEssentialGraph answers (optimisesLocalMaps() and LoopClosing.Planar).
  bool optimisesEssentialGraphs() const;
  // The essential graph on SE(2): vision's relative poses (information from graph_sigma_*) and the
  // wheel edges between keyframes consecutive in time (as in optimiseLocalMap), so that the
  // loop's correction goes where vision and the wheels together are least sure. Safe to call from
  // ORB-SLAM3's loop closing thread. False (nothing written) when optimisesEssentialGraphs() is false.
  bool optimiseEssentialGraph(const EssentialGraph& graph, EssentialGraphSolution* solution);
  // The odometry's calibration as the local maps have refined it: distance scale, turn scale
  // (relative, 0: as configured), curvature (rad/m) (rvwo/edges/wheel_preintegration.h).
  Eigen::Vector3d calibration() const;
  // Frames tracked (frameTracked) whose last optimisePose had vision alone overrule the wheels.
  std::size_t slipFrames() const;
  // Local maps optimiseLocalMap solved, and those of them that refined the calibration. ORB-SLAM3
  // skips a local map while keyframes wait: fed faster than real time, mono solved 7 to 15 in
  // 90 s, and the wheels' turn error went unlearnt in some runs.
  std::size_t localMapsSolved() const;
  std::size_t localMapsCalibrated() const;

  // ---- labels (eqs. 4, 5)
  // The segmenter keyframes go to, run in a thread of its own (its labels in the label set of the
  // settings); none: no keyframe is segmented, reliabilities learn from reprojection errors alone.
  void setSegmenter(const std::shared_ptr<Segmenter>& segmenter);
  bool segments() const;
  // The frame's image as Tracking was given it (BGR or BGRA, rectified like the grey one it makes;
  // OpenCV's channel order whatever Camera.RGB says), kept for the keyframe the frame may become:
  // the segmenter's network needs colour. A reference, not a copy; nothing kept without a segmenter.
  void frameImage(const cv::Mat& image);
  // A keyframe: its image (8-bit grey; copied) and its keypoints that see map points. The
  // segmenter sees the frame's colour image instead when frameImage gave one of the same size.
  // Never waits: labels that have come are applied here and before each optimisePose; when
  // keyframes come faster than the segmenter, the oldest waiting one is dropped.
  void keyFrame(double t, const cv::Mat& image, const std::vector<KeyFrameFeature>& features);
  // Waits up to timeout_s for the labels of the keyframes sent, and applies them (shutdown, tests).
  void waitForLabels(double timeout_s);
  std::size_t segmentedKeyFrames() const;
  // A map point's Barron shape as tracking weighs it (eq. 7): 1 for a fresh one, -inf rejected.
  double alpha(unsigned long id) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace orbslam3
}  // namespace rvwo
