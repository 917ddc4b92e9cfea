// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/estimator/options.h"

#include <cmath>
#include <stdexcept>

namespace rvwo::estimator {
namespace {

Eigen::Isometry3d isometry(const Settings& s, const std::string& key, bool required) {
  const auto m = s.matrix(key, 4, 4);
  if (!m) {
    if (required) throw std::invalid_argument(s.path() + ": missing key " + key);
    return Eigen::Isometry3d::Identity();
  }
  Eigen::Matrix4d M = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(m->data());
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || std::fabs(R.determinant() - 1) > 1e-6 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
    throw std::invalid_argument(s.path() + ": " + key + " is not a rigid transform (rotation and translation)");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

}  // namespace

Rig readRig(const Settings& s) {
  Rig rig;
  const std::string sensor = s.text("Sensor").value_or("stereo");
  if (sensor == "stereo") {
    rig.sensor = Sensor::kStereo;
  } else if (sensor == "rgbd") {
    rig.sensor = Sensor::kRgbd;
  } else if (sensor == "mono") {
    rig.sensor = Sensor::kMono;
  } else {
    throw std::invalid_argument(s.path() + ": Sensor must be \"stereo\", \"rgbd\" or \"mono\"");
  }
  const double fx = s.requireNumber("Camera1.fx"), fy = s.requireNumber("Camera1.fy");
  const double cx = s.requireNumber("Camera1.cx"), cy = s.requireNumber("Camera1.cy");
  if (!(fx > 0 && fy > 0)) throw std::invalid_argument(s.path() + ": Camera1.fx and Camera1.fy must be > 0");
  const std::string type = s.text("Camera.type").value_or("PinHole");
  if (type == "PinHole") {
    rig.camera = std::make_shared<PinholeCamera>(fx, fy, cx, cy);
  } else if (type == "KannalaBrandt8") {
    rig.camera = std::make_shared<KannalaBrandtCamera>(fx, fy, cx, cy, s.requireNumber("Camera1.k1"),
                                                       s.requireNumber("Camera1.k2"), s.requireNumber("Camera1.k3"),
                                                       s.requireNumber("Camera1.k4"));
  } else {
    throw std::invalid_argument(s.path() + ": Camera.type must be \"PinHole\" or \"KannalaBrandt8\"");
  }
  rig.width = static_cast<int>(s.requireNumber("Camera.width"));
  rig.height = static_cast<int>(s.requireNumber("Camera.height"));
  rig.fps = s.requireNumber("Camera.fps");
  if (rig.width <= 0 || rig.height <= 0 || !(rig.fps > 0))
    throw std::invalid_argument(s.path() + ": Camera.width, Camera.height and Camera.fps must be > 0");
  if (rig.sensor == Sensor::kStereo) {
    rig.baseline = s.requireNumber("Stereo.b");
  } else {
    rig.baseline = s.number("Stereo.b").value_or(0.08);  // RGB-D: a virtual baseline for u_R
  }
  if (!(rig.baseline > 0)) throw std::invalid_argument(s.path() + ": Stereo.b must be > 0");
  if (rig.sensor == Sensor::kRgbd) {
    rig.depth_factor = s.requireNumber("RGBD.DepthMapFactor");
    if (!(rig.depth_factor > 0)) throw std::invalid_argument(s.path() + ": RGBD.DepthMapFactor must be > 0");
  }
  rig.T_b_c = isometry(s, "Camera.T_b_c", true);
  const Eigen::Isometry3d T_b_o = isometry(s, "Odometry.T_b_o", false);
  rig.T_b_o =
      SE2(T_b_o.translation().x(), T_b_o.translation().y(), std::atan2(T_b_o.linear()(1, 0), T_b_o.linear()(0, 0)));
  return rig;
}

EstimatorOptions readEstimatorOptions(const Settings& s, EstimatorOptions o) {
  auto num = [&](const char* key, auto* member) {
    if (const auto v = s.number(key)) *member = static_cast<std::remove_pointer_t<decltype(member)>>(*v);
  };
  num("Estimator.Features", &o.features);
  num("Estimator.ScaleFactor", &o.scale_factor);
  num("Estimator.Levels", &o.levels);
  num("Estimator.FastThreshold", &o.fast_threshold);
  num("Estimator.SearchRadius", &o.search_radius);
  num("Estimator.MinInliers", &o.min_inliers);
  num("Estimator.CloseDepthBaselines", &o.max_depth_baselines);
  num("Estimator.KeyFrameMaxFrames", &o.keyframe_max_frames);
  num("Estimator.KeyFrameRatio", &o.keyframe_ratio);
  num("Estimator.Window", &o.window);
  num("Estimator.KeepKeyFrames", &o.keep_keyframes);
  num("Estimator.SigmaPx", &o.sigma_px);
  num("Estimator.BarronScale", &o.barron_scale);
  num("Estimator.LabelDilation", &o.label_dilation_px);
  num("Estimator.SigmaZ", &o.out_of_plane.sigma_z);
  if (const auto v = s.number("Estimator.SigmaRollPitch"))
    o.out_of_plane.sigma_rollpitch = Eigen::Matrix2d::Identity() * (*v) * (*v);
  o.wheel_noise = readWheelNoise(s, o.wheel_noise);
  num("Odometry.WheelRadiusLeft", &o.drive.radius_left);
  num("Odometry.WheelRadiusRight", &o.drive.radius_right);
  num("Odometry.Track", &o.drive.track);
  o.reliability = readReliability(s, o.reliability);
  o.priors = readSemanticPriors(s);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.path() + ": " + e.what());
  }
  return o;
}

}  // namespace rvwo::estimator
