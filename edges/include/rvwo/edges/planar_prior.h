// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Planar prior for hosts that keep 6-DoF poses (ORB-SLAM3's SE(3) vertices): a unary factor that
// holds the body near the floor plane. The plane is the xy-plane of a frame T_w_p (for ORB-SLAM3,
// the body frame of the first keyframe); with T_p_b = T_w_p^-1 T_w_b = (R, p):
//
//   r = [ p_z ;  (R e_z)_x ;  (R e_z)_y ]      height above the plane, then tilt (~ pitch, -roll)
//
// Jacobian w.r.t. a right perturbation of T_w_b, T_w_b Exp(delta), delta = (omega, v) (rotation
// first, both in the body frame): dr/domega = [0; -R [e_z]x rows 0, 1], dr/dv = [e_z^T R; 0].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rvwo {

class PlanarPrior {
 public:
  // sigma_z in m, sigma_tilt in rad (1-sigma of each tilt component).
  PlanarPrior(const Eigen::Isometry3d& T_w_p, double sigma_z, double sigma_tilt);
  Eigen::Vector3d residual(const Eigen::Isometry3d& T_w_b, Eigen::Matrix<double, 3, 6>* J = nullptr) const;
  // diag(1/sigma_z^2, 1/sigma_tilt^2, 1/sigma_tilt^2)
  Eigen::Matrix3d information() const { return information_; }

 private:
  Eigen::Isometry3d T_p_w_;
  Eigen::Matrix3d information_;
};

}  // namespace rvwo
