// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// WheelInput in ORB-SLAM3's pose type (Sophus::SE3f, as T_c_w). Included by the patched
// Tracking.cc, whose include path has ORB-SLAM3's bundled Sophus; C++11.
#pragma once

#include <sophus/se3.hpp>

#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

inline Eigen::Isometry3d toIsometry(const Sophus::SE3f& T) {
  Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  I.linear() = T.rotationMatrix().cast<double>();
  I.translation() = T.translation().cast<double>();
  return I;
}

inline Sophus::SE3f toSophus(const Eigen::Isometry3d& T) {
  // Through a normalised quaternion: Sophus checks that the rotation is one in float.
  return Sophus::SE3f(Eigen::Quaternionf(Eigen::Quaterniond(T.linear()).normalized().cast<float>()),
                      T.translation().cast<float>());
}

// T_cj_w of the frame at tj from T_ci_w of the frame at ti.
inline Sophus::SE3f predict(const WheelInput& wheels, const Sophus::SE3f& T_ci_w, double ti, double tj) {
  return toSophus(wheels.predict(toIsometry(T_ci_w), ti, tj));
}

}  // namespace orbslam3
}  // namespace rvwo
