// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/estimator/options.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace rvwo::estimator {
namespace {

cv::Mat cameraMatrix(const CameraModel& c) {
  return cv::Mat_<double>({3, 3}, {c.fx(), 0, c.cx(), 0, c.fy(), c.cy(), 0, 0, 1});
}

}  // namespace

void StereoRectification::rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_out,
                                  cv::Mat* right_out) const {
  cv::remap(left, *left_out, left_x, left_y, cv::INTER_LINEAR);
  if (!right_x.empty()) cv::remap(right, *right_out, right_x, right_y, cv::INTER_LINEAR);
}

cv::Mat StereoRectification::rectifyLeftLabels(const cv::Mat& labels) const {
  cv::Mat out;
  cv::remap(labels, out, left_x, left_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(-1));
  return out;
}

cv::Mat StereoRectification::rectifyLeftDepth(const cv::Mat& depth) const {
  cv::Mat out;
  cv::remap(depth, out, left_x, left_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

void undistortPinhole(const std::array<double, 5>& d, Rig* rig) {
  const cv::Mat K = cameraMatrix(*rig->camera);
  auto r = std::make_shared<StereoRectification>();
  cv::initUndistortRectifyMap(K, cv::Mat_<double>({5, 1}, {d[0], d[1], d[2], d[3], d[4]}), cv::Mat(), K,
                              cv::Size(rig->width, rig->height), CV_32FC1, r->left_x, r->left_y);
  rig->rectification = r;
  rig->radtan = d;
}

void rectifyFisheyeStereo(const KannalaBrandtCamera& left, const KannalaBrandtCamera& right,
                          const Eigen::Isometry3d& T_c1_c2, Rig* rig) {
  auto D = [](const KannalaBrandtCamera& c) -> cv::Mat {
    return cv::Mat_<double>({4, 1}, {c.k()(0), c.k()(1), c.k()(2), c.k()(3)});
  };
  // OpenCV's R, T take the left camera's coordinates to the right's: T_c2_c1.
  const Eigen::Isometry3d T_c2_c1 = T_c1_c2.inverse();
  cv::Mat R(3, 3, CV_64F), T(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    T.at<double>(i) = T_c2_c1.translation()(i);
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = T_c2_c1.linear()(i, j);
  }
  const cv::Size size(rig->width, rig->height);
  cv::Mat R1, R2, P1, P2, Q;
  // balance 0: the rectified view keeps only pixels both raw images have.
  cv::fisheye::stereoRectify(cameraMatrix(left), D(left), cameraMatrix(right), D(right), size, R, T, R1, R2, P1, P2, Q,
                             cv::CALIB_ZERO_DISPARITY, size, 0.0, 1.0);
  auto table = std::make_shared<StereoRectification>();
  cv::fisheye::initUndistortRectifyMap(cameraMatrix(left), D(left), R1, P1, size, CV_32FC1, table->left_x,
                                       table->left_y);
  cv::fisheye::initUndistortRectifyMap(cameraMatrix(right), D(right), R2, P2, size, CV_32FC1, table->right_x,
                                       table->right_y);
  const double fx = P1.at<double>(0, 0);
  rig->camera = std::make_shared<PinholeCamera>(fx, P1.at<double>(1, 1), P1.at<double>(0, 2), P1.at<double>(1, 2));
  rig->baseline = std::fabs(P2.at<double>(0, 3)) / fx;  // P2 = [K' | -K' (b, 0, 0)]
  // R1 turns the raw left camera's coordinates into the rectified one's: T_c1_rect = [R1^T | 0].
  Eigen::Matrix3d R1e;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R1e(i, j) = R1.at<double>(i, j);
  Eigen::Isometry3d T_c1_rect = Eigen::Isometry3d::Identity();
  T_c1_rect.linear() = R1e.transpose();
  rig->T_b_c = rig->T_b_c * T_c1_rect;
  rig->rectification = std::move(table);
}

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
  std::array<double, 5> radtan{};  // ORB-SLAM3's radial-tangential keys of a PinHole camera
  if (type == "PinHole") {
    const char* keys[5] = {"Camera1.k1", "Camera1.k2", "Camera1.p1", "Camera1.p2", "Camera1.k3"};
    for (int i = 0; i < 5; ++i) {
      radtan[i] = s.number(keys[i]).value_or(0.0);
      if (radtan[i] != 0.0 && sensor == "stereo")
        throw std::invalid_argument(s.path() + ": " + keys[i] +
                                    " is not 0: a stereo pair is taken rectified (Stereo.b), without distortion");
    }
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
  if (rig.sensor == Sensor::kStereo && type == "KannalaBrandt8") {
    const double fx2 = s.requireNumber("Camera2.fx"), fy2 = s.requireNumber("Camera2.fy");
    if (!(fx2 > 0 && fy2 > 0)) throw std::invalid_argument(s.path() + ": Camera2.fx and Camera2.fy must be > 0");
    const KannalaBrandtCamera right(fx2, fy2, s.requireNumber("Camera2.cx"), s.requireNumber("Camera2.cy"),
                                    s.requireNumber("Camera2.k1"), s.requireNumber("Camera2.k2"),
                                    s.requireNumber("Camera2.k3"), s.requireNumber("Camera2.k4"));
    const Eigen::Isometry3d T_c1_c2 = readIsometry(s, "Stereo.T_c1_c2", true);
    if (!(T_c1_c2.translation().norm() > 0))
      throw std::invalid_argument(s.path() + ": Stereo.T_c1_c2 must separate the cameras");
    rig.T_b_c = readIsometry(s, "Camera.T_b_c", true);
    rectifyFisheyeStereo(static_cast<const KannalaBrandtCamera&>(*rig.camera), right, T_c1_c2, &rig);
  } else if (rig.sensor == Sensor::kStereo) {
    rig.baseline = s.requireNumber("Stereo.b");
  } else {
    rig.baseline = s.number("Stereo.b").value_or(0.08);  // RGB-D: a virtual baseline for u_R
  }
  if (!(rig.baseline > 0)) throw std::invalid_argument(s.path() + ": Stereo.b must be > 0");
  if (rig.sensor == Sensor::kRgbd) {
    rig.depth_factor = s.requireNumber("RGBD.DepthMapFactor");
    if (!(rig.depth_factor > 0)) throw std::invalid_argument(s.path() + ": RGBD.DepthMapFactor must be > 0");
  }
  if (!rig.rectification) rig.T_b_c = readIsometry(s, "Camera.T_b_c", true);  // (a fisheye pair's: set above)
  if (radtan != std::array<double, 5>{}) undistortPinhole(radtan, &rig);
  const Eigen::Isometry3d T_b_o = readIsometry(s, "Odometry.T_b_o", false);
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
  num("Estimator.CloseDepthBaselines", &o.max_depth_baselines);
  num("Estimator.MonoMinBaseline", &o.mono_min_baseline);
  num("Estimator.MonoMinParallax", &o.mono_min_parallax);
  num("Estimator.KeyFrameMaxFrames", &o.keyframe_max_frames);
  num("Estimator.KeyFrameRatio", &o.keyframe_ratio);
  num("Estimator.Window", &o.window);
  num("Estimator.KeepKeyFrames", &o.keep_keyframes);
  num("Estimator.MonoMaxMappingLag", &o.mono_max_mapping_lag);
  num("Estimator.SigmaPx", &o.sigma_px);
  o.label_dilation_px = readLabelDilation(s, o.label_dilation_px, "Estimator.LabelDilation");
  o.tracking = readTrackingOptions(s, o.tracking);
  o.wheel_noise = readWheelNoise(s, o.wheel_noise);
  o.drive = readDiffDrive(s, o.drive);
  if (const auto v = s.number("Odometry.Calibrate")) o.calibrate = *v != 0;
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
