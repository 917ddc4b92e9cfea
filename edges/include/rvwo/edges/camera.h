// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Camera models: projection of a point in the camera frame (x right, y down, z forward) to pixels,
// with its 2x3 Jacobian. Pinhole (undistorted or rectified images) and Kannala-Brandt with four
// coefficients (ORB-SLAM3's KannalaBrandt8; the RealSense T265 of OpenLORIS is one). Rectified
// stereo and RGB-D add a right-image column u_R = u_L - bf / z (Se2XyzEdge), as ORB-SLAM3 does.
#pragma once

#include <Eigen/Core>
#include <memory>

namespace rvwo {

class CameraModel {
 public:
  enum class Kind { kPinhole, kKannalaBrandt8 };
  virtual ~CameraModel() = default;
  virtual Kind kind() const = 0;
  // Pixel of P_c (z > 0 for the pinhole; any direction within the fisheye's field for KB8).
  virtual Eigen::Vector2d project(const Eigen::Vector3d& P_c, Eigen::Matrix<double, 2, 3>* J = nullptr) const = 0;
  // A ray through the pixel: z = 1 for the pinhole, unit length for KB8.
  virtual Eigen::Vector3d unproject(const Eigen::Vector2d& uv) const = 0;
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }

 protected:
  CameraModel(double fx, double fy, double cx, double cy);
  double fx_, fy_, cx_, cy_;
};

class PinholeCamera final : public CameraModel {
 public:
  PinholeCamera(double fx, double fy, double cx, double cy) : CameraModel(fx, fy, cx, cy) {}
  Kind kind() const override { return Kind::kPinhole; }
  Eigen::Vector2d project(const Eigen::Vector3d& P_c, Eigen::Matrix<double, 2, 3>* J = nullptr) const override;
  Eigen::Vector3d unproject(const Eigen::Vector2d& uv) const override;
};

// r = |(x, y)|, theta = atan2(r, z), d(theta) = theta + k1 theta^3 + k2 theta^5 + k3 theta^7 +
// k4 theta^9, (u, v) = (fx d x / r + cx, fy d y / r + cy).
class KannalaBrandtCamera final : public CameraModel {
 public:
  KannalaBrandtCamera(double fx, double fy, double cx, double cy, double k1, double k2, double k3, double k4);
  Kind kind() const override { return Kind::kKannalaBrandt8; }
  Eigen::Vector2d project(const Eigen::Vector3d& P_c, Eigen::Matrix<double, 2, 3>* J = nullptr) const override;
  Eigen::Vector3d unproject(const Eigen::Vector2d& uv) const override;
  const Eigen::Vector4d& k() const { return k_; }

 private:
  Eigen::Vector4d k_;
};

}  // namespace rvwo
