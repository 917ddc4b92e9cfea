// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/wheel_edge.h"

#include <Eigen/Cholesky>
#include <stdexcept>

namespace rvwo {

Eigen::Vector3d wheelResidual(const Eigen::Vector3d& x_i, const Eigen::Vector3d& x_j, const Eigen::Vector2d& dp,
                              double dphi, Eigen::Matrix3d* J_i, Eigen::Matrix3d* J_j) {
  const Eigen::Matrix2d R_i_T = rotation2(x_i.z()).transpose();  // R(-phi_i)
  const Eigen::Vector2d d = x_j.head<2>() - x_i.head<2>();
  const Eigen::Vector2d p_ij = R_i_T * d;
  Eigen::Vector3d r;
  r.head<2>() = p_ij - dp;
  r.z() = wrapAngle(x_j.z() - x_i.z() - dphi);
  if (J_i) {
    J_i->setZero();
    J_i->block<2, 2>(0, 0) = -R_i_T;
    // d R(-phi)/d phi = -J R(-phi), so d(R(-phi_i) d)/d phi_i = -J R(-phi_i) d.
    J_i->block<2, 1>(0, 2) = -perp(p_ij);
    (*J_i)(2, 2) = -1.0;
  }
  if (J_j) {
    J_j->setZero();
    J_j->block<2, 2>(0, 0) = R_i_T;
    (*J_j)(2, 2) = 1.0;
  }
  return r;
}

WheelEdge::WheelEdge(const WheelDelta& delta) : delta_(delta) {
  const Eigen::LLT<Eigen::Matrix3d> llt(delta.covariance);
  if (llt.info() != Eigen::Success || !delta.covariance.allFinite()) {
    throw std::invalid_argument("WheelEdge: the delta's covariance is not positive definite");
  }
  information_ = llt.solve(Eigen::Matrix3d::Identity());
  information_ = 0.5 * (information_ + information_.transpose());
  // S = L^-1 with Sigma = L L^T gives S^T S = Sigma^-1; S is lower triangular.
  sqrt_information_ = llt.matrixL().solve(Eigen::Matrix3d::Identity());
}

}  // namespace rvwo
