// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// SE(2) wheel-odometry edge (RVWO paper eq. 14; docs/maths.md section 5) between the planar poses
// x_i = (p_i, phi_i), x_j = (p_j, phi_j) of two keyframes, from their preintegrated wheel delta:
//
//   r = [ R(-phi_i)(p_j - p_i) - Dp ;  wrap(phi_j - phi_i - Dphi) ],   information Sigma^-1
//
//   dr_p/dp_i = -R(-phi_i),  dr_p/dphi_i = -J R(-phi_i)(p_j - p_i),  dr_p/dp_j = R(-phi_i)
//   dr_phi/dphi_i = -1,      dr_phi/dphi_j = 1
#pragma once

#include <Eigen/Core>

#include "rvwo/edges/wheel_preintegration.h"

namespace rvwo {

// Residual of eq. 14 with optional Jacobians w.r.t. (x, y, theta) of each pose.
Eigen::Vector3d wheelResidual(const Eigen::Vector3d& x_i, const Eigen::Vector3d& x_j, const Eigen::Vector2d& dp,
                              double dphi, Eigen::Matrix3d* J_i = nullptr, Eigen::Matrix3d* J_j = nullptr);

class WheelEdge {
 public:
  // Throws std::invalid_argument when the delta's covariance is not positive definite.
  explicit WheelEdge(const WheelDelta& delta);
  Eigen::Vector3d residual(const Eigen::Vector3d& x_i, const Eigen::Vector3d& x_j, Eigen::Matrix3d* J_i = nullptr,
                           Eigen::Matrix3d* J_j = nullptr) const {
    return wheelResidual(x_i, x_j, delta_.dp, delta_.dphi, J_i, J_j);
  }
  // The same with the odometry's calibration c as a variable: the delta at c to first order
  // (WheelDelta::at), so dr/dc = -d_calibration.
  Eigen::Vector3d residual(const Eigen::Vector3d& x_i, const Eigen::Vector3d& x_j, const WheelCalibration& c,
                           Eigen::Matrix3d* J_i, Eigen::Matrix3d* J_j, Eigen::Matrix3d* J_c) const {
    const Eigen::Vector3d d = delta_.at(c);
    if (J_c) *J_c = -delta_.d_calibration;
    return wheelResidual(x_i, x_j, d.head<2>(), d.z(), J_i, J_j);
  }
  const WheelDelta& delta() const { return delta_; }
  const Eigen::Matrix3d& information() const { return information_; }
  // S (lower triangular) with S^T S = information: whitened residual = S r (for Ceres).
  const Eigen::Matrix3d& sqrtInformation() const { return sqrt_information_; }

 private:
  WheelDelta delta_;
  Eigen::Matrix3d information_;
  Eigen::Matrix3d sqrt_information_;
};

}  // namespace rvwo
