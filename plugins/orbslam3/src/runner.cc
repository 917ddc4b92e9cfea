// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "rvwo/orbslam3/runner.h"

#include <ORBVocabulary.h>  // ORB-SLAM3's
#include <ORBextractor.h>
#include <System.h>  // patched
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "rvwo/settings/settings.h"

namespace rvwo::orbslam3 {
namespace {

std::string matrixEntry(const std::string& key, const Eigen::Isometry3d& T) {
  std::ostringstream s;
  s.precision(17);
  s << key << ": !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) s << (r || c ? ", " : "") << T.matrix()(r, c);
  }
  s << "]\n";
  return s.str();
}

// EuRoC lines as ORB-SLAM3 writes them: t[ns] tx ty tz qx qy qz qw.
std::vector<std::pair<double, Eigen::Isometry3d>> readEuroc(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("ORB-SLAM3 wrote no trajectory (" + path + ")");
  std::vector<std::pair<double, Eigen::Isometry3d>> out;
  double t, x, y, z, qx, qy, qz, qw;
  while (in >> t >> x >> y >> z >> qx >> qy >> qz >> qw) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    T.translation() << x, y, z;
    out.emplace_back(t * 1e-9, T);
  }
  return out;
}

// ORB-SLAM3 reads its real-valued keys as reals only: 400 must be written 400.0.
std::string real(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.12g", x);
  std::string s = buf;
  if (s.find_first_of(".en") == std::string::npos) s += ".0";
  return s;
}

}  // namespace

void writeOrbSlam3Settings(const std::string& path, RunnerOptions::Sensor sensor, const OrbSlam3Camera& c,
                           const OrbSlam3Features& f, const WheelInputParams* wheels,
                           const std::vector<std::pair<std::string, std::string>>& more) {
  std::ofstream out(path);
  out.precision(12);
  // Upstream's older settings format (no File.version): v1.0's new one crashes printing a
  // "Rectified" stereo pair (Settings.cc dereferences the second camera it does not have).
  out << "%YAML:1.0\n# ORB-SLAM3 v1.0 settings, written by rvwo-replay --backend orbslam3\n";
  out << "Camera.type: \"PinHole\"\n";
  out << "Camera.fx: " << real(c.fx) << "\nCamera.fy: " << real(c.fy) << "\nCamera.cx: " << real(c.cx)
      << "\nCamera.cy: " << real(c.cy) << "\n";
  // ORB-SLAM3 undistorts the keypoints of a mono or RGB-D camera itself; stereo images come rectified.
  const char* radtan_keys[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (int i = 0; i < 5; ++i) out << "Camera." << radtan_keys[i] << ": " << real(c.radtan[i]) << "\n";
  out << "Camera.width: " << c.width << "\nCamera.height: " << c.height << "\nCamera.fps: " << int(std::lround(c.fps))
      << "\nCamera.RGB: 0\n";
  if (sensor != RunnerOptions::Sensor::kMono)
    out << "Camera.bf: " << real(c.baseline * c.fx) << "\nThDepth: " << real(f.close_depth_baselines) << "\n";
  if (sensor == RunnerOptions::Sensor::kRgbd) out << "DepthMapFactor: 1.0\n";
  out << "ORBextractor.nFeatures: " << f.features << "\nORBextractor.scaleFactor: " << real(f.scale_factor)
      << "\nORBextractor.nLevels: " << f.levels << "\nORBextractor.iniThFAST: " << f.fast_threshold
      << "\nORBextractor.minThFAST: " << f.min_fast_threshold << "\n";
  // No viewer runs, but ORB-SLAM3 requires its keys.
  out << "Viewer.KeyFrameSize: 0.05\nViewer.KeyFrameLineWidth: 1.0\nViewer.GraphLineWidth: 0.9\n"
         "Viewer.PointSize: 2.0\nViewer.CameraSize: 0.08\nViewer.CameraLineWidth: 3.0\nViewer.ViewpointX: 0.0\n"
         "Viewer.ViewpointY: -0.7\nViewer.ViewpointZ: -1.8\nViewer.ViewpointF: 500.0\n";
  if (wheels) {
    out << "# RVWO's wheel input (patches/orbslam3)\n";
    out << "Sensor: \"" << (sensor == RunnerOptions::Sensor::kMono ? "mono" : "stereo") << "\"\n";
    if (wheels->wheels) {
      out << matrixEntry("Camera.T_b_c", wheels->T_b_c) << matrixEntry("Odometry.T_b_o", wheels->T_b_o);
      out << "Odometry.WheelRadiusLeft: " << real(wheels->radius_left)
          << "\nOdometry.WheelRadiusRight: " << real(wheels->radius_right)
          << "\nOdometry.Track: " << real(wheels->track) << "\n";
      out << "Tracking.Planar: " << (wheels->planar ? 1 : 0) << "\n";
    } else {
      out << "Odometry.Input: \"none\"  # RVWO's vision alone: labels and adaptive kernels in 6-DoF tracking\n";
    }
    out << "Tracking.Kernel: \"" << (wheels->huber ? "huber" : "adaptive") << "\"\n";
    writeTrackingOptions(out, wheels->tracking);
    if (wheels->wheels) {
      out << "LocalMapping.Planar: " << (wheels->local_map ? 1 : 0)
          << "\nLocalMapping.MaxWheelSpan: " << real(wheels->max_wheel_span)
          << "\nLocalMapping.SpinMinFrames: " << wheels->spin_min_frames
          << "\nOdometry.Calibrate: " << (wheels->calibrate ? 1 : 0) << "\n";
    }
    for (const auto& [key, value] : more) out << key << ": " << value << "\n";
  }
  if (!out.flush()) throw std::runtime_error("cannot write " + path);
}

std::size_t buildVocabulary(const std::vector<cv::Mat>& images, const OrbSlam3Features& f, int k, int L,
                            const std::string& path) {
  ORB_SLAM3::ORBextractor extractor(f.features, float(f.scale_factor), f.levels, f.fast_threshold,
                                    f.min_fast_threshold);
  std::vector<std::vector<cv::Mat>> training;
  for (const cv::Mat& image : images) {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    std::vector<int> lapping = {0, 0};
    extractor(image, cv::Mat(), keypoints, descriptors, lapping);
    training.emplace_back();
    for (int r = 0; r < descriptors.rows; ++r) training.back().push_back(descriptors.row(r));
  }
  ORB_SLAM3::ORBVocabulary vocabulary(k, L, DBoW2::TF_IDF, DBoW2::L1_NORM);
  vocabulary.create(training);
  vocabulary.saveToTextFile(path);
  // DBoW2's loadFromTextFile reads a last, empty word when the file ends with a newline (every
  // line saveToTextFile writes ends with one): cut it.
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in || in.tellg() <= 0) throw std::runtime_error("cannot write " + path);
  const auto size = static_cast<std::uintmax_t>(in.tellg());
  in.seekg(-1, std::ios::end);
  if (in.get() == '\n') {
    in.close();
    std::error_code error;
    std::filesystem::resize_file(path, size - 1, error);
    if (error) throw std::runtime_error("cannot write " + path + ": " + error.message());
  }
  return vocabulary.size();
}

struct Runner::Impl {
  RunnerOptions options;
  std::ofstream log;
  std::streambuf* cout_buf = nullptr;
  std::unique_ptr<ORB_SLAM3::System> system;
  std::vector<WheelReading> wheels;
  bool finished = false;
};

Runner::Runner(const RunnerOptions& o) : impl_(std::make_unique<Impl>()) {
  impl_->options = o;
  if (!std::ifstream(o.vocabulary)) throw std::runtime_error("cannot read the vocabulary " + o.vocabulary);
  if (!o.log.empty()) {
    impl_->log.open(o.log);
    if (!impl_->log) throw std::runtime_error("cannot write " + o.log);
    impl_->cout_buf = std::cout.rdbuf(impl_->log.rdbuf());  // ORB-SLAM3 talks on std::cout
  }
  const auto sensor = o.sensor == RunnerOptions::Sensor::kStereo ? ORB_SLAM3::System::STEREO
                      : o.sensor == RunnerOptions::Sensor::kRgbd ? ORB_SLAM3::System::RGBD
                                                                 : ORB_SLAM3::System::MONOCULAR;
  impl_->system = std::make_unique<ORB_SLAM3::System>(o.vocabulary, o.settings, sensor, false);
}

Runner::~Runner() {
  if (impl_->system && !impl_->finished) impl_->system->Shutdown();
  if (impl_->cout_buf) std::cout.rdbuf(impl_->cout_buf);
  // ORB-SLAM3 leaves its threads running after Shutdown (upstream's examples exit the process);
  // the System is not destroyed under them.
  (void)impl_->system.release();
}

void Runner::addWheels(const WheelReading& r) { impl_->wheels.push_back(r); }

void Runner::setSegmenter(const std::shared_ptr<Segmenter>& segmenter) {
  WheelInput& w = impl_->system->Wheels();  // patch 0002
  if (w.active()) w.setSegmenter(segmenter);
}

bool Runner::track(double t, const cv::Mat& image, const cv::Mat& right_or_depth) {
  ORB_SLAM3::System& s = *impl_->system;
  // The wheel overloads (patch 0002), with or without readings: without, ORB-SLAM3 tracks as
  // upstream.
  switch (impl_->options.sensor) {
    case RunnerOptions::Sensor::kStereo:
      s.TrackStereo(image, right_or_depth, t, impl_->wheels);
      break;
    case RunnerOptions::Sensor::kRgbd:
      s.TrackRGBD(image, right_or_depth, t, impl_->wheels);
      break;
    case RunnerOptions::Sensor::kMono:
      s.TrackMonocular(image, t, impl_->wheels);
      break;
  }
  impl_->wheels.clear();
  return s.GetTrackingState() == ORB_SLAM3::Tracking::OK;
}

Runner::Result Runner::finish(const std::string& scratch) {
  ORB_SLAM3::System& s = *impl_->system;
  s.Shutdown();
  impl_->finished = true;
  // Shutdown only asks local mapping and loop closing to stop: let them.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  Result r;
  const std::string frames = scratch + "frames.txt", keyframes = scratch + "keyframes.txt";
  s.SaveTrajectoryEuRoC(frames);
  s.SaveKeyFrameTrajectoryEuRoC(keyframes);
  r.T_c0_c = readEuroc(frames);
  r.keyframes = readEuroc(keyframes).size();
  WheelInput& w = s.Wheels();  // patch 0002
  r.wheel_only_frames = w.wheelOnlyFrames();
  r.segmented_keyframes = w.segmentedKeyFrames();
  r.wheel_only_intervals = w.wheelOnlyIntervals();
  r.slip_frames = w.slipFrames();
  r.wheel_calibration = w.calibration();
  r.local_maps = w.localMapsSolved();
  r.calibrated_local_maps = w.localMapsCalibrated();
  std::remove(frames.c_str());
  std::remove(keyframes.c_str());
  return r;
}

}  // namespace rvwo::orbslam3
