// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "rvwo/orbslam3/wheel_input.h"

#include <cmath>
#include <stdexcept>

#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/settings/settings.h"

namespace rvwo::orbslam3 {
namespace {

SE2 planar(const Eigen::Isometry3d& T) {
  return SE2(T.translation().x(), T.translation().y(), std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
}

}  // namespace

struct WheelInput::Impl {
  WheelInputParams params;
  DiffDriveParams drive;
  WheelOdometry odometry;
  std::size_t wheel_frames = 0;
  int run = 0;  // frames on the wheels in a row, this one included
  bool keyframe = false;
  std::vector<std::pair<double, double>> intervals;
};

WheelInput::WheelInput() = default;
WheelInput::~WheelInput() = default;

void WheelInput::configure(const WheelInputParams& p) {
  auto impl = std::make_unique<Impl>();
  impl->params = p;
  impl->drive.radius_left = p.radius_left;
  impl->drive.radius_right = p.radius_right;
  impl->drive.track = p.track;
  impl->drive.validate();
  impl->odometry = WheelOdometry(WheelNoise(), planar(p.T_b_o));
  impl_ = std::move(impl);
}

void WheelInput::configure(const std::string& settings_path) {
  const Settings s = Settings::load(settings_path);
  if (!s.has("Camera.T_b_c") && s.keysWithPrefix("Odometry.").empty()) {
    impl_.reset();
    return;
  }
  WheelInputParams p;
  p.T_b_c = readIsometry(s, "Camera.T_b_c", true);
  p.T_b_o = readIsometry(s, "Odometry.T_b_o", false);
  const DiffDriveParams d = readDiffDrive(s);
  p.radius_left = d.radius_left;
  p.radius_right = d.radius_right;
  p.track = d.track;
  const std::string sensor = s.text("Sensor").value_or("stereo");
  p.map_from_depth = sensor != "mono";
  configure(p);
}

bool WheelInput::active() const { return impl_ != nullptr; }

void WheelInput::add(const std::vector<WheelReading>& readings) {
  if (!impl_) {
    if (readings.empty()) return;
    throw std::invalid_argument(
        "wheel readings given, but the settings have no Camera.T_b_c (RVWO's wheel input is off)");
  }
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
  if (!impl_ || impl_->odometry.empty() || !(ti <= tj)) return false;
  return impl_->odometry.firstTime() <= ti && tj <= impl_->odometry.lastTime();
}

Eigen::Isometry3d WheelInput::predict(const Eigen::Isometry3d& T_ci_w, double ti, double tj) const {
  if (!covers(ti, tj)) throw std::out_of_range("wheel readings do not cover the frames' times");
  const Eigen::Isometry3d T_bi_bj = impl_->odometry.integrate(ti, tj).pose().isometry3();
  const Eigen::Isometry3d& T_b_c = impl_->params.T_b_c;
  return T_b_c.inverse() * T_bi_bj.inverse() * T_b_c * T_ci_w;
}

void WheelInput::frameTracked(double t, bool visual, int features) {
  if (!impl_) return;
  Impl& m = *impl_;
  // Predictions start at the last frame: a second before it is margin enough (bounded memory).
  m.odometry.dropBefore(t - 1.0);
  if (visual) {
    m.run = 0;
    m.keyframe = false;
    return;
  }
  ++m.wheel_frames;
  if (m.run++ == 0) {
    m.intervals.emplace_back(t, t);
  } else {
    m.intervals.back().second = t;
  }
  // A frame held on the wheels past a momentary failure, with features again: a keyframe now
  // and then gives tracking new map points at the wheel pose (stereo and RGB-D only: a monocular
  // keyframe alone makes none).
  m.keyframe = m.params.map_from_depth && features >= m.params.min_features && m.run >= 2 &&
               (m.run - 2) % m.params.keyframe_every == 0;
}

bool WheelInput::keyFrameNeeded() const { return impl_ && impl_->keyframe; }

std::size_t WheelInput::wheelOnlyFrames() const { return impl_ ? impl_->wheel_frames : 0; }

std::vector<std::pair<double, double>> WheelInput::wheelOnlyIntervals() const {
  return impl_ ? impl_->intervals : std::vector<std::pair<double, double>>{};
}

}  // namespace rvwo::orbslam3
