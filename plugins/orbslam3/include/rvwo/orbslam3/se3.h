// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// ORB-SLAM3's pose type (Sophus::SE3f, a T_c_w) read and made without Sophus: read through
// rotationMatrix() and translation(), made from a quaternion and a translation. So the plugin's
// templates need neither ORB-SLAM3's headers nor Sophus, and CI tests them on stand-ins. C++11.
#pragma once

#include <Eigen/Geometry>

namespace rvwo {
namespace orbslam3 {

template <class PoseT>
Eigen::Isometry3d isometryOf(const PoseT& T) {
  Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  I.linear() = T.rotationMatrix().template cast<double>();
  I.translation() = T.translation().template cast<double>();
  return I;
}

// Through a normalised quaternion: Sophus checks that the rotation is one in float.
template <class PoseT>
PoseT poseOf(const Eigen::Isometry3d& T) {
  return PoseT(Eigen::Quaternionf(Eigen::Quaterniond(T.linear()).normalized().cast<float>()),
               Eigen::Vector3f(T.translation().cast<float>()));
}

}  // namespace orbslam3
}  // namespace rvwo
