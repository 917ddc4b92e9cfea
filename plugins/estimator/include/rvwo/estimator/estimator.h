// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The RVWO estimator (paper sec. III): visual-wheel odometry on SE(2) with adaptive kernels.
//
//   tracking (III-C)       ORB features; stereo matching or depth; the pose predicted from the
//                          wheel preintegration; map points tracked by projection; pose-only
//                          optimisation on SE(2) with SE(2)-XYZ edges, the wheel edge to the
//                          previous frame and each landmark's kernel. Too few inliers (lens
//                          covered, no texture): the pose follows the wheels, and the map resumes
//                          from there when features come back (new keyframe at the wheel pose:
//                          no jump).
//   initialisation (III-B) the first keyframe at the origin of the odometry; its points from
//                          stereo or depth (the metric scale needs no visual initialisation).
//   local mapping (III-D)  keyframes every few frames or when tracking thins; new points from
//                          stereo or depth; the reliability model fed by labels and
//                          reprojection errors; local bundle adjustment on SE(2) over a window of
//                          keyframes (SE(2)-XYZ edges, wheel edges between consecutive keyframes,
//                          adaptive kernels; Ceres, sparse Schur); culling of points that are
//                          rarely found and of keyframes that leave the window (their poses are
//                          final and their points forgotten: memory stays bounded).
//   segmentation           keyframes go to a Segmenter in its own thread (AsyncSegmenter); labels
//                          that come back feed the landmarks' semantic filter (eqs. 4, 5).
//
// Feed it in time order: addOdometry*() and addFrame(). A frame is processed once the odometry
// has passed its time (or at finish()), so odometry may lag the camera. Frames' poses are those
// of the robot's base frame; they are refined while their keyframe is in the window.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "rvwo/edges/se2.h"
#include "rvwo/estimator/options.h"
#include "rvwo/semantics/segmenter.h"

namespace rvwo::estimator {

// One camera frame. image: 8-bit grey or BGR (left for stereo); right: the rectified right image
// (stereo); depth: CV_16U raw units or CV_32F (RGB-D, registered to image).
struct FrameInput {
  double timestamp = 0;  // s
  cv::Mat image, right, depth;
};

struct TimingStats {  // ms
  double mean = 0, p50 = 0, p95 = 0, max = 0;
  std::size_t count = 0;
  // Of a stage's durations, ms (none: all zero).
  static TimingStats of(std::vector<double> ms);
};

struct Report {
  std::size_t frames = 0, keyframes = 0, wheel_only_frames = 0;
  std::vector<std::pair<double, double>> wheel_only_intervals;  // [t0, t1] s, frames on wheels only
  std::size_t map_points_created = 0, map_points_rejected = 0;  // rejected: alpha = -inf when they left the map
  // The map at the end: keyframes and points in memory (what local mapping and tracking search),
  // and keyframes that left it (only their poses kept, for the trajectory).
  std::size_t map_keyframes = 0, map_points = 0, retired_keyframes = 0;
  std::size_t segmented_keyframes = 0;
  std::size_t segmentation_failures = 0;  // keyframes whose labels could not be used (segmenter failed, wrong size)
  std::string segmentation_error;         // the first such failure, in words
  std::size_t slip_frames = 0;          // frames where vision alone explained clearly more than vision with the wheels
  std::size_t wheel_edge_outliers = 0;  // wheel edges local BA found contradicted by vision (slips, skids)
  std::size_t relocalisations = 0;      // blind frames placed on the map by descriptor matching
  std::size_t wheel_gated = 0;          // frames placed by the landmarks the wheels explain (wheel_gate)
  WheelCalibration wheel_calibration = WheelCalibration::Zero();  // the odometry's, as estimated (vw)
  std::vector<std::pair<std::string, TimingStats>> timings;       // per stage
};

struct PoseEstimate {
  double timestamp = 0;
  SE2 T_w_b;            // robot base in the world (the odometry's start = the origin)
  bool visual = false;  // false: the pose followed the wheels (or, without wheels, the motion model)
};

class Estimator {
 public:
  // segmenter: labels for keyframes (nullptr, or options.semantics false: none).
  // Throws std::invalid_argument for inconsistent options.
  Estimator(const Rig& rig, const EstimatorOptions& options, std::shared_ptr<Segmenter> segmenter = nullptr);
  ~Estimator();
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // Odometry readings (rvwo/edges/wheel_preintegration.h), in time order. Throws
  // std::invalid_argument (NaN, time not increasing): the caller may skip the reading and go on.
  void addOdometryPose(double t, const SE2& T_odom_o);
  void addWheelAngles(double t, double q_left, double q_right);
  void addWheelSpeeds(double t, double w_left, double w_right);
  // Throws std::invalid_argument for an image of the wrong size or type, or a timestamp not after
  // the previous frame's.
  void addFrame(const FrameInput& frame);
  // Processes what is pending, waits for the threads and runs a last local BA.
  void finish();

  // Poses of every frame processed so far (final for keyframes that left the window).
  std::vector<PoseEstimate> trajectory() const;
  Report report() const;
  // Called after each frame is processed, with its (first) estimate: for progress lines.
  void setFrameCallback(std::function<void(const PoseEstimate&)> callback);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rvwo::estimator
