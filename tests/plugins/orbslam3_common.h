// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// What the ORB-SLAM3 plugin's tests share: a camera on the robot, the frames between ORB-SLAM3's
// world (its first camera's frame) and the robot's plane, which lies T_b_c under it, and
// stand-ins for ORB-SLAM3's pose type and Map.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <mutex>
#include <vector>

#include "../common/cameras.h"
#include "../common/draw.h"
#include "rvwo/edges/se2.h"

namespace rvwo::test {

// As Sophus::SE3f: read through rotationMatrix() and translation(), made from (q, t).
struct Pose {
  Pose() = default;
  Pose(const Eigen::Quaternionf& q, const Eigen::Vector3f& t) : R(q.toRotationMatrix()), t(t) {}
  Eigen::Matrix3f rotationMatrix() const { return R; }
  Eigen::Vector3f translation() const { return t; }
  Eigen::Matrix3f R = Eigen::Matrix3f::Identity();
  Eigen::Vector3f t = Eigen::Vector3f::Zero();
};

// As ORB-SLAM3's GeometricCamera, as far as the plugin asks (rig.h): its model.
struct Camera {
  static const unsigned int CAM_PINHOLE = 0, CAM_FISHEYE = 1;
  unsigned int type = CAM_PINHOLE;
  unsigned int GetType() const { return type; }
};
inline Camera* pinholeCamera() {
  static Camera c;
  return &c;
}
inline Camera* fisheyeCamera() {
  static Camera c{Camera::CAM_FISHEYE};
  return &c;
}

// As ORB-SLAM3's Map, over a test's stand-ins for KeyFrame and MapPoint (its first keyframe: id 0).
template <class KeyFrameT, class MapPointT>
struct MapOf {
  std::mutex mMutexMapUpdate;
  int changes = 0;
  std::vector<KeyFrameT*> keyframes;
  std::vector<MapPointT*> points;
  unsigned long GetInitKFid() const { return 0; }
  void IncreaseChangeIndex() { ++changes; }
  std::vector<KeyFrameT*> GetAllKeyFrames() const { return keyframes; }
  std::vector<MapPointT*> GetAllMapPoints() const { return points; }
  KeyFrameT* GetOriginKF() const { return keyframes.front(); }
};

// Looking ahead, pitched up 5 deg (the tests always had it so; their comment said down), 0.25 m
// ahead, 3 cm left, 0.4 m up.
inline Eigen::Isometry3d tiltedCamera() { return lookingAhead(-5 * M_PI / 180, Eigen::Vector3d(0.25, 0.03, 0.4)); }

// T_c_w in ORB-SLAM3's world of the camera on a robot at x_w_b.
inline Eigen::Isometry3d cameraPose(const SE2& x_w_b, const Eigen::Isometry3d& T_b_c) {
  return (T_b_c.inverse() * x_w_b.isometry3() * T_b_c).inverse();
}

// The robot pose a camera pose T_c_w means, and how far that camera pose is off the plane.
inline SE2 robotOf(const Eigen::Isometry3d& T_c_w, const Eigen::Isometry3d& T_b_c, double* off_plane) {
  const Eigen::Isometry3d T_w_b = T_b_c * T_c_w.inverse() * T_b_c.inverse();
  *off_plane = std::fabs(T_w_b.translation().z()) + std::fabs(T_w_b.linear()(2, 2) - 1.0);
  return SE2(T_w_b.translation().x(), T_w_b.translation().y(), std::atan2(T_w_b.linear()(1, 0), T_w_b.linear()(0, 0)));
}

}  // namespace rvwo::test
