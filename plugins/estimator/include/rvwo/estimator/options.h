// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What the RVWO estimator needs to know: the rig (camera, extrinsic, stereo baseline or depth
// scale), the wheels' noise, the reliability model and the estimator's own knobs. readOptions()
// fills it from a settings YAML (docs/rawlog.md, keys below); tests fill it by hand.
//
//   Sensor: "stereo" | "rgbd" | "mono"                   Camera.type: "PinHole" | "KannalaBrandt8"
//   Camera1.fx/fy/cx/cy [px], Camera1.k1..k4 (fisheye)    Camera.width/height [px], Camera.fps [Hz]
//   Stereo.b [m] (rectified stereo; RGB-D: the virtual baseline, default 0.08)
//   fisheye stereo: Camera2.fx/fy/cx/cy/k1..k4, Stereo.T_c1_c2 (4x4: the right camera in the left's frame)
//   RGBD.DepthMapFactor [raw units per metre]             Camera.T_b_c, Odometry.T_b_o: 4x4 matrices
//   Odometry.*, Reliability.*, Semantics.*                (rvwo/settings/settings.h)
//   Estimator.*: the knobs of EstimatorOptions below, e.g. Estimator.Features: 1000
//   Tracking.*: the tracking core's policy (TrackingOptions), e.g. Tracking.MinInliers: 20
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "rvwo/edges/camera.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/kernels/reliability.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/settings/settings.h"

namespace rvwo::estimator {

enum class Sensor { kStereo, kRgbd, kMono };
// What the estimator fuses: wheels only (dead reckoning), vision only, or both (RVWO).
enum class Mode { kWheel, kVo, kVw };
// The robust kernel on the visual residuals: Huber (ORB-SLAM's), a fixed Barron shape, or each
// landmark's shape from the reliability model (the paper's adaptive kernel, eq. 7).
enum class KernelChoice { kHuber, kFixed, kAdaptive };

// The raw images onto the rig's pinhole camera, on input: a fisheye stereo pair (ORB-SLAM3's
// KannalaBrandt8 stereo: Camera1.*, Camera2.*, Stereo.T_c1_c2) rectified into a pinhole pair
// (cv::fisheye::stereoRectify), or one radial-tangential camera (PinHole with Camera1.k1, k2, p1,
// p2, k3) undistorted, same intrinsics. These tables map the raw images (and the left one's labels
// and depth) onto the rig's.
struct StereoRectification {
  cv::Mat left_x, left_y, right_x, right_y;  // cv::remap tables: raw pixel of each rectified one (no right: one camera)
  void rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_out, cv::Mat* right_out) const;
  cv::Mat rectifyLeftLabels(const cv::Mat& labels) const;  // nearest label, -1 outside the raw image
  cv::Mat rectifyLeftDepth(const cv::Mat& depth) const;    // nearest depth, 0 (none) outside
};

struct Rig {
  Sensor sensor = Sensor::kStereo;
  std::shared_ptr<const CameraModel> camera;                 // pinhole for stereo and RGB-D (rectified)
  std::shared_ptr<const StereoRectification> rectification;  // fisheye stereo, radial-tangential: raw to pinhole
  std::array<double, 5> radtan{};                            // the raw camera's k1, k2, p1, p2, k3 that
                                                             // rectification undoes (0: none)
  int width = 640, height = 480;                             // px
  double fps = 30;                                           // Hz
  double baseline = 0.12;                                    // m (RGB-D: virtual, for the u_R coordinate)
  double depth_factor = 1000;                                // RGB-D raw depth units per metre
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();   // camera in the robot's base frame
  SE2 T_b_o;                                                 // odometry frame in the base frame
  double bf() const;                                         // baseline * fx, px m
};

// The rectified pinhole pair of two Kannala-Brandt cameras, the right one at T_c1_c2 in the
// left's frame, images rig.width x rig.height. Sets rig.camera, rig.baseline and rig.rectification, and
// turns rig.T_b_c (the raw left camera's) into the rectified left camera's.
void rectifyFisheyeStereo(const KannalaBrandtCamera& left, const KannalaBrandtCamera& right,
                          const Eigen::Isometry3d& T_c1_c2, Rig* rig);
// One pinhole camera with radial-tangential distortion (OpenCV's k1, k2, p1, p2, k3), images
// rig.width x rig.height: sets rig.rectification to undistort it onto rig.camera's intrinsics, and
// rig.radtan.
void undistortPinhole(const std::array<double, 5>& k1_k2_p1_p2_k3, Rig* rig);

struct EstimatorOptions {
  Mode mode = Mode::kVw;
  KernelChoice kernel = KernelChoice::kAdaptive;
  double fixed_alpha = 1.0;  // KernelChoice::kFixed
  bool semantics = true;     // labels feed the reliability model (off: reprojection errors only)
  // One thread, everything inline (local mapping and segmentation wait for each keyframe): the
  // same input gives the same trajectory, bit for bit. Otherwise local mapping and segmentation
  // run in threads of their own.
  bool deterministic = false;

  // ---- features (Estimator.Features, .ScaleFactor, .Levels, .FastThreshold)
  int features = 1000;        // ORB keypoints per image, spread over a grid
  double scale_factor = 1.2;  // pyramid
  // Six levels span a scale of 2.5, plenty for a ground robot (docs/decisions/0007).
  int levels = 6;
  int fast_threshold = 12;
  // ---- tracking
  double search_radius = 12;        // px at level 0, projection search (Estimator.SearchRadius)
  double max_depth_baselines = 40;  // close points (ORB-SLAM's ThDepth): new points closer than this many baselines
  // ---- mono and RGB-D: points triangulated between keyframes whose poses the wheels scale
  double mono_min_baseline =
      0.05;  // m between camera centres; less (a turn on the spot) triangulates nothing (Estimator.MonoMinBaseline)
  double mono_min_parallax = 1.0;  // degrees between the two rays of a new point (Estimator.MonoMinParallax)
  // ---- the tracking core's policy (Tracking.*: MinInliers, SlipMinInliers, SlipHold,
  // SlipHoldMinFrames, TrustedMaxPs, SlipCheck, WheelGate, BarronScale, SigmaZ, SigmaRollPitch;
  // rvwo/tracking/options.h, docs/estimator.md)
  TrackingOptions tracking;
  // ---- keyframes and local mapping
  int keyframe_max_frames = 15;  // a keyframe at least this often (frames) while tracking
  double keyframe_ratio = 0.75;  // or when fewer than this share of the reference keyframe's points are tracked
  int window = 8;                // keyframes optimised by local BA (Estimator.Window)
  int keep_keyframes = 14;       // keyframes kept in memory (window + fixed neighbours)
  // Mono, threaded: tracking waits for local mapping once the keyframe it has not finished is
  // this many seconds of data old (Estimator.MonoMaxMappingLag; 0: tracking never runs past an
  // unmapped keyframe's next frame). Stereo and RGB-D do not wait (docs/decisions/0005).
  double mono_max_mapping_lag = 0.25;
  // ---- noise
  double sigma_px = 1.0;  // keypoint noise at level 0, px
  WheelNoise wheel_noise;
  DiffDriveParams drive;
  // ---- the odometry's calibration c (rvwo/edges/wheel_preintegration.h), refined by local BA in
  // vw (Odometry.Calibrate: 1 | 0): a prior around zero (counted in the first BA, then a bound at
  // 3 sigma), and one around the last estimate in every BA: how far one BA may move it, a random
  // walk in time (ceres_adapters::wheelCalibrationStep; docs/decisions/0001).
  bool calibrate = true;
  Eigen::Vector3d calibration_sigma{0.05, 0.05, 0.2};     // distance scale, turn scale, curvature (rad/m)
  Eigen::Vector3d calibration_step{0.003, 0.003, 0.005};  // the same, per local BA calibration_period after the last
  double calibration_period = 0.5;                        // s: keyframes come about this often where nothing moves
  ReliabilityParams reliability;
  SemanticPriors priors = SemanticPriors::builtin("voc21");
  int label_dilation_px = 8;  // px: dynamic classes' masks widened, edges least sure (Segmentation.LabelDilation)

  // Throws std::invalid_argument naming the setting of the first inconsistent value.
  void validate() const;
};

// The rig from settings (Sensor, Camera.*, Camera1.*, Stereo.b, RGBD.DepthMapFactor,
// Camera.T_b_c, Odometry.T_b_o). Throws std::invalid_argument "<file>: missing key <key>" or
// naming the key of a wrong value.
Rig readRig(const Settings& settings);
// Estimator.*, Tracking.*, Odometry.*, Reliability.*, Semantics.* over the given defaults (mode, kernel and
// the switches stay as given: they are the caller's). Throws std::invalid_argument naming the key.
EstimatorOptions readEstimatorOptions(const Settings& settings, EstimatorOptions defaults = {});

}  // namespace rvwo::estimator
