// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// Drives a patched ORB-SLAM3 (patches/orbslam3/) frame by frame, for rvwo-replay's
// `--backend orbslam3`: built only when CMake is given ORB_SLAM3_ROOT. Nothing of ORB-SLAM3 shows
// in this header.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo::orbslam3 {

struct RunnerOptions {
  enum class Sensor { kMono, kStereo, kRgbd };
  std::string vocabulary;  // DBoW2 text vocabulary (ORBvoc.txt, or rvwo-orbslam3-vocab's)
  std::string settings;    // ORB-SLAM3's settings YAML (writeOrbSlam3Settings)
  Sensor sensor = Sensor::kStereo;
  std::string log;  // file that takes ORB-SLAM3's console output ("": left on stdout)
};

// What ORB-SLAM3's settings need, from RVWO's rig (pinhole, rectified: stereo, RGB-D, mono).
struct OrbSlam3Camera {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // px
  int width = 0, height = 0;              // px
  double fps = 30;                        // Hz
  double baseline = 0;                    // m (RGB-D: virtual, for ORB-SLAM3's stereo coordinate)
  std::array<double, 5> radtan{};         // k1, k2, p1, p2, k3 of the images (mono, RGB-D; 0: undistorted)
};
struct OrbSlam3Features {
  int features = 1200;  // per image (upstream's examples: 1000-1250)
  double scale_factor = 1.2;
  int levels = 8;
  int fast_threshold = 20, min_fast_threshold = 7;
  double close_depth_baselines = 40;  // Stereo.ThDepth: points nearer are "close"
};

// Writes ORB-SLAM3 v1.0's settings (its older format, which v1.0 reads too). With wheels (RVWO's
// keys Camera.T_b_c, Odometry.*, Tracking.*) the patched ORB-SLAM3 fuses the wheels and optimises
// poses on SE(2); with wheels->wheels false (Odometry.Input: "none") it runs RVWO's labels and
// kernels in its own 6-DoF tracking; with nullptr it runs as upstream. `more`: further RVWO keys
// with their YAML values (Odometry.Noise*, Reliability.*), written with RVWO's only. Throws
// std::runtime_error when the file cannot be written.
void writeOrbSlam3Settings(const std::string& path, RunnerOptions::Sensor sensor, const OrbSlam3Camera& camera,
                           const OrbSlam3Features& features, const WheelInputParams* wheels,
                           const std::vector<std::pair<std::string, std::string>>& more = {});

// Builds a DBoW2 vocabulary (k^L words at most; TF-IDF, L1 score as upstream's ORBvoc.txt) from
// the ORB features ORB-SLAM3's own extractor finds in the images, and writes it as text for
// ORB-SLAM3. Returns the number of words. Throws std::runtime_error when it cannot be written.
std::size_t buildVocabulary(const std::vector<cv::Mat>& images, const OrbSlam3Features& features, int k, int L,
                            const std::string& path);

class Runner {
 public:
  // Loads the vocabulary (a minute for upstream's ORBvoc.txt, a second for a small one) and
  // starts ORB-SLAM3's threads, without its viewer.
  explicit Runner(const RunnerOptions& options);
  ~Runner();
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  // A wheel reading, handed to ORB-SLAM3 with the next frame.
  void addWheels(const WheelReading& reading);
  // The segmenter ORB-SLAM3's keyframes go to (patch 0005), when the wheels are configured.
  void setSegmenter(const std::shared_ptr<Segmenter>& segmenter);
  // One frame (grey 8-bit; right: the right image for stereo, depth in metres, CV_32F, for
  // RGB-D). Returns whether ORB-SLAM3 tracks after it (false: lost, not initialised).
  bool track(double t, const cv::Mat& image, const cv::Mat& right_or_depth);
  // Stops ORB-SLAM3 and returns each frame's T_c0_c (c0: the first keyframe of its largest map)
  // as ORB-SLAM3 saves them (refined by local BA and loop closing; frames it lost are absent),
  // and the keyframe count; with wheels, the plugin's counts (WheelInput). `scratch` is a file
  // prefix for ORB-SLAM3's trajectory files.
  struct Result {
    std::vector<std::pair<double, Eigen::Isometry3d>> T_c0_c;
    std::size_t keyframes = 0;
    std::size_t wheel_only_frames = 0;                            // frames the wheels placed
    std::vector<std::pair<double, double>> wheel_only_intervals;  // [first, last] frame time of each stretch
    std::size_t slip_frames = 0;                                  // frames where vision overruled the wheels
    std::size_t segmented_keyframes = 0;                          // keyframes whose labels came
    Eigen::Vector3d wheel_calibration = Eigen::Vector3d::Zero();  // as the local maps refined it
    std::size_t local_maps = 0, calibrated_local_maps = 0;        // solved on SE(2); of those, refining it
  };
  Result finish(const std::string& scratch);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rvwo::orbslam3
