// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "scenario.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <sstream>
#include <stdexcept>

#include "support/trajectory.h"

namespace rvwo::sim {
namespace {

std::vector<Interval> intervals(const cv::FileNode& n, const std::string& key, const std::string& file, int per,
                                bool gain) {
  std::vector<Interval> out;
  if (n.empty() || n.isNone()) return out;
  if (!n.isSeq()) throw std::runtime_error(file + ": " + key + ": expected a list [t0, t1, ...]");
  std::vector<double> v;
  for (const auto& e : n) v.push_back(static_cast<double>(e));
  if (v.size() % per != 0) throw std::runtime_error(file + ": " + key + ": expected groups of " + std::to_string(per));
  for (std::size_t i = 0; i < v.size(); i += per) {
    if (gain) {
      out.push_back({v[i], 1e18, v[i + 1]});
    } else {
      if (!(v[i + 1] > v[i])) throw std::runtime_error(file + ": " + key + ": an interval ends before it starts");
      out.push_back({v[i], v[i + 1], per == 3 ? v[i + 2] : 1.0});
    }
  }
  return out;
}

// A number under key into v, left as it is when the key is absent.
void number(const cv::FileStorage& fs, const char* key, const std::string& path, double& v) {
  const cv::FileNode n = fs[key];
  if (n.empty() || n.isNone()) return;
  if (!n.isReal() && !n.isInt()) throw std::runtime_error(path + ": " + key + ": expected a number");
  v = static_cast<double>(n);
}

// Camera.* and Depth.*: the camera's and the depth sensor's effects.
void readEffects(const cv::FileStorage& fs, const std::string& path, Scenario* s) {
  auto num = [&](const char* key, double& v) { number(fs, key, path, v); };
  CameraEffects& c = s->camera_effects;
  num("Camera.Exposure", c.exposure);
  num("Camera.RowDelay", c.row_delay);
  num("Camera.Vignetting", c.vignetting);
  num("Camera.AutoExposure", c.auto_exposure);
  num("Camera.ExposureTarget", c.exposure_target);
  num("Camera.MaxGain", c.max_gain);
  num("Camera.ShotNoise", c.shot_noise);
  double quality = c.jpeg_quality;
  num("Camera.JpegQuality", quality);
  c.jpeg_quality = static_cast<int>(quality);
  DepthEffects& d = s->depth_effects;
  num("Depth.Noise", d.noise);
  num("Depth.MaxIncidence", d.max_incidence);
  num("Depth.MinAlbedo", d.min_albedo);
  const cv::FileNode shift = fs["Depth.Misregistration"];
  if (!shift.empty() && !shift.isNone()) {
    if (!shift.isSeq() || shift.size() != 2) {
      throw std::runtime_error(path + ": Depth.Misregistration: expected [x, y] in pixels");
    }
    d.shift_x = static_cast<double>(shift[0]);
    d.shift_y = static_cast<double>(shift[1]);
  }
}

}  // namespace

Scenario loadScenario(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": scenario not found");
  std::stringstream text;
  text << in.rdbuf();
  Scenario s = parseScenario(text.str(), path, std::filesystem::path(path).parent_path().string());
  s.name = std::filesystem::path(path).stem().string();
  return s;
}

Scenario parseScenario(const std::string& text, const std::string& path, const std::string& folder) {
  Scenario s;
  s.text = text;
  cv::FileStorage fs;
  try {
    fs.open(s.text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": not a scenario YAML file (%YAML:1.0 first): " + e.err);
  }
  auto num = [&](const char* key, double& v) { number(fs, key, path, v); };
  auto integer = [&](const char* key, int& v) {
    double d = v;
    num(key, d);
    v = static_cast<int>(d);
  };
  auto str = [&](const char* key, std::string& v) {
    const cv::FileNode n = fs[key];
    if (n.empty() || n.isNone()) return;
    if (!n.isString()) throw std::runtime_error(path + ": " + key + ": expected a string");
    v = static_cast<std::string>(n);
  };
  s.name = path;
  num("Sequence.Duration", s.duration);
  str("Sequence.Camera", s.camera);
  str("Sequence.Lens", s.lens);
  num("Sequence.Fps", s.fps);
  num("Sequence.PixelNoise", s.camera_effects.read_noise);
  str("Sequence.Motion", s.motion);
  str("Sequence.MotionFile", s.motion_file);
  num("Sequence.MotionSpeed", s.motion_speed);
  num("Camera.Fx", s.focal);
  num("Camera.Baseline", s.baseline);
  integer("Sequence.MotionBlock", s.motion_block);
  num("Sequence.LoopSpeed", s.loop_speed);
  num("Room.SizeX", s.room_x);
  num("Room.SizeY", s.room_y);
  num("Room.Height", s.room_h);
  integer("Room.Furniture", s.furniture);
  num("Odometry.Rate", s.odometry_rate);
  num("Odometry.RadiusError", s.radius_error);
  num("Odometry.TrackError", s.track_error);
  num("Odometry.NoiseWheel", s.wheel_noise);
  integer("Odometry.TicksPerRevolution", s.ticks_per_revolution);
  integer("Walkers.Count", s.walkers);
  integer("Walkers.Escorts", s.escorts);
  num("Walkers.Speed", s.walker_speed);
  str("Walkers.Look", s.walker_look);
  readEffects(fs, path, &s);
  s.slip = intervals(fs["Events.Slip"], "Events.Slip", path, 2, false);
  s.blackout = intervals(fs["Events.Blackout"], "Events.Blackout", path, 2, false);
  s.low_texture = intervals(fs["Events.LowTexture"], "Events.LowTexture", path, 3, false);
  s.bumps = intervals(fs["Events.Bumps"], "Events.Bumps", path, 3, false);
  s.illumination = intervals(fs["Events.Illumination"], "Events.Illumination", path, 2, true);
  validateScenario(s, path);
  if (s.motion == "file" && std::filesystem::path(s.motion_file).is_relative()) {
    s.motion_file = (std::filesystem::path(folder) / s.motion_file).string();
  }
  return s;
}

void validateScenario(const Scenario& s, const std::string& source) {
  auto check = [&](bool ok, const char* key, const char* what) {
    if (!ok) throw std::runtime_error(source + ": " + key + ": " + what);
  };
  check(s.duration > 0, "Sequence.Duration", "must be > 0");
  check(s.camera == "stereo" || s.camera == "rgbd" || s.camera == "mono", "Sequence.Camera", "stereo, rgbd or mono");
  check(s.lens == "pinhole" || s.lens == "fisheye", "Sequence.Lens", "pinhole or fisheye");
  check(s.lens == "pinhole" || s.camera != "rgbd", "Sequence.Lens", "fisheye is simulated for mono and stereo");
  check(s.fps > 0 && s.fps <= 120, "Sequence.Fps", "must be in (0, 120]");
  check(s.focal == 0 || (s.focal >= 100 && s.focal <= 2000), "Camera.Fx",
        "must be 0 (the lens's own) or in [100, 2000] px");
  check(s.baseline >= 0.02 && s.baseline <= 1, "Camera.Baseline", "must be in [0.02, 1] m");
  check(s.motion_speed >= 0.25 && s.motion_speed <= 4, "Sequence.MotionSpeed", "must be in [0.25, 4]");
  const CameraEffects& c = s.camera_effects;
  check(c.read_noise >= 0 && c.read_noise <= 50, "Sequence.PixelNoise", "must be in [0, 50] grey levels");
  check(c.exposure >= 0 && c.exposure <= 1 / s.fps, "Camera.Exposure", "must be in [0, 1 / Sequence.Fps] s");
  check(std::fabs(c.row_delay) <= 1e-3, "Camera.RowDelay", "must be in [-0.001, 0.001] s a row");
  check(c.vignetting >= 0 && c.vignetting < 1, "Camera.Vignetting", "must be in [0, 1)");
  check(c.auto_exposure >= 0, "Camera.AutoExposure", "must be >= 0 s (0: fixed gain)");
  check(c.exposure_target > 0 && c.exposure_target < 255, "Camera.ExposureTarget", "must be in (0, 255) grey levels");
  check(c.max_gain >= 1, "Camera.MaxGain", "must be >= 1");
  check(c.shot_noise >= 0 && c.shot_noise <= 10, "Camera.ShotNoise", "must be in [0, 10] grey levels");
  check(c.jpeg_quality >= 0 && c.jpeg_quality <= 100, "Camera.JpegQuality", "must be in [0, 100] (0: no JPEG)");
  const DepthEffects& d = s.depth_effects;
  check(d.noise >= 0, "Depth.Noise", "must be >= 0 (0: none)");
  check(d.max_incidence > 0 && d.max_incidence <= 90, "Depth.MaxIncidence", "must be in (0, 90] degrees");
  check(d.min_albedo >= 0 && d.min_albedo <= 255, "Depth.MinAlbedo", "must be in [0, 255] grey levels");
  check(std::fabs(d.shift_x) <= 20 && std::fabs(d.shift_y) <= 20, "Depth.Misregistration",
        "must be within 20 pixels each way");
  check(s.motion == "loop" || s.motion == "file", "Sequence.Motion", "loop or file");
  check(s.motion != "file" || !s.motion_file.empty(), "Sequence.MotionFile", "needed with Sequence.Motion: file");
  check(s.odometry_rate >= 1 && s.odometry_rate <= 1000, "Odometry.Rate", "must be in [1, 1000] Hz");
  check(s.ticks_per_revolution > 0, "Odometry.TicksPerRevolution", "must be > 0");
  check(s.walkers >= 0 && s.walkers <= 50, "Walkers.Count", "must be in [0, 50]");
  check(s.escorts >= 0 && s.escorts <= 10, "Walkers.Escorts", "must be in [0, 10]");
  check(s.walker_look == "people" || s.walker_look == "cylinders", "Walkers.Look", "people or cylinders");
}

Motion::Motion(const Scenario& s) {
  if (s.motion == "loop") {
    // Laps of a rounded rectangle 2 m inside the room's walls: straights and quarter turns.
    const double r = 1.0, a = s.room_x - 4 - 2 * r, b = s.room_y - 4 - 2 * r;
    if (a <= 0 || b <= 0) throw std::runtime_error("the room is too small for the loop");
    const double quarter = 0.5 * M_PI * r, len[8] = {a, quarter, b, quarter, a, quarter, b, quarter};
    const double lap = 2 * (a + b) + 4 * quarter;
    for (double t = 0; t <= s.duration + 1e-9; t += 0.01) {
      double d = std::fmod(s.loop_speed * t, lap);
      SE2 T(-a / 2, -s.room_y / 2 + 2, 0.0);
      for (int i = 0; i < 8 && d > 0; ++i) {
        const double step = std::min(d, len[i]);
        T = T * SE2::exp(Eigen::Vector3d(step, 0, (i % 2 ? 1 / r : 0) * step));
        d -= step;
      }
      t_.push_back(t);
      pose_.push_back(T);
    }
  } else {
    // A real trajectory: the chosen block, its plane fitted (PCA) and turned to z up, the
    // heading taken from the body axis that best follows the direction of travel.
    const apps::Trajectory traj = apps::readTum(s.motion_file, s.motion_block, /*lenient=*/true);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& p : traj) mean += p.T.translation() / traj.size();
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (const auto& p : traj) C += (p.T.translation() - mean) * (p.T.translation() - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(C);
    Eigen::Vector3d n = eig.eigenvectors().col(0);  // smallest spread: the plane's normal
    if (n.z() < 0) n = -n;
    const Eigen::Matrix3d R_p_w = Eigen::Quaterniond::FromTwoVectors(n, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    // Heading axis: the body axis whose projection best follows the velocity.
    const Eigen::Vector3d axes[6] = {Eigen::Vector3d::UnitX(),  -Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                     -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),  -Eigen::Vector3d::UnitZ()};
    double score[6] = {0, 0, 0, 0, 0, 0};
    for (std::size_t k = 1; k < traj.size(); ++k) {
      const Eigen::Vector3d v = R_p_w * (traj[k].T.translation() - traj[k - 1].T.translation());
      for (int a = 0; a < 6; ++a) {
        Eigen::Vector3d h = R_p_w * traj[k].T.linear() * axes[a];
        h.z() = 0;
        score[a] += h.normalized().dot(Eigen::Vector3d(v.x(), v.y(), 0));
      }
    }
    const int best = static_cast<int>(std::max_element(score, score + 6) - score);
    // A differential drive cannot move sideways, but the rows do (ground-truth noise: in
    // OpenLORIS home1 a step's lateral motion is often 10 to 30 % of its forward motion). Each
    // step's sideways part is dropped and the path re-integrated from its forward motion and turn,
    // so that wheels without error measure the ground truth exactly and every error the
    // odometry has is one the scenario asked for.
    const double t0 = traj.front().t;
    SE2 previous_row;
    for (const auto& p : traj) {
      const double t = (p.t - t0) / s.motion_speed;
      if (t > s.duration + 1e-9) break;
      const Eigen::Vector3d x = R_p_w * (p.T.translation() - mean);
      const Eigen::Vector3d h = R_p_w * p.T.linear() * axes[best];
      const SE2 row(x.x(), x.y(), std::atan2(h.y(), h.x()));
      if (pose_.empty()) {
        pose_.push_back(row);
      } else {
        const Eigen::Vector3d xi = previous_row.between(row).log();
        pose_.push_back(pose_.back() * SE2::exp(Eigen::Vector3d(xi.x(), 0.0, xi.z())));
      }
      t_.push_back(t);
      previous_row = row;
    }
  }
  if (t_.size() < 2) throw std::runtime_error("the motion has fewer than two poses");
  duration_ = t_.back();
  min_ = max_ = pose_.front().translation();
  for (const SE2& p : pose_) {
    min_ = min_.cwiseMin(p.translation());
    max_ = max_.cwiseMax(p.translation());
  }
}

SE2 Motion::at(double t) const {
  t = std::clamp(t, t_.front(), t_.back());
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  const std::size_t k = it == t_.end() ? t_.size() - 1 : static_cast<std::size_t>(it - t_.begin());
  if (k == 0) return pose_.front();
  const double f = (t - t_[k - 1]) / (t_[k] - t_[k - 1]);
  return pose_[k - 1] * pose_[k - 1].between(pose_[k]).fraction(f);
}

}  // namespace rvwo::sim
