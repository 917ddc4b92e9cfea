// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/planar_prior.h"

#include <cmath>
#include <stdexcept>

namespace rvwo {

PlanarPrior::PlanarPrior(const Eigen::Isometry3d& T_w_p, double sigma_z, double sigma_tilt) : T_p_w_(T_w_p.inverse()) {
  if (!(sigma_z > 0 && sigma_tilt > 0 && std::isfinite(sigma_z) && std::isfinite(sigma_tilt))) {
    throw std::invalid_argument("PlanarPrior: sigma_z and sigma_tilt must be finite and > 0");
  }
  information_ = Eigen::Vector3d(1 / (sigma_z * sigma_z), 1 / (sigma_tilt * sigma_tilt), 1 / (sigma_tilt * sigma_tilt))
                     .asDiagonal();
}

Eigen::Vector3d PlanarPrior::residual(const Eigen::Isometry3d& T_w_b, Eigen::Matrix<double, 3, 6>* J) const {
  const Eigen::Isometry3d T_p_b = T_p_w_ * T_w_b;
  const Eigen::Matrix3d R = T_p_b.linear();
  const Eigen::Vector3d Rz = R.col(2);
  if (J) {
    // d(R Exp(w) e_z)/dw = -R [e_z]x;  [e_z]x = [[0, -1, 0], [1, 0, 0], [0, 0, 0]]
    Eigen::Matrix3d ez_x = Eigen::Matrix3d::Zero();
    ez_x(0, 1) = -1.0;
    ez_x(1, 0) = 1.0;
    const Eigen::Matrix3d d_tilt = -R * ez_x;
    J->setZero();
    J->block<1, 3>(0, 3) = R.row(2);  // d p_z / d v = e_z^T R
    J->block<2, 3>(1, 0) = d_tilt.topRows<2>();
  }
  return {T_p_b.translation().z(), Rz.x(), Rz.y()};
}

}  // namespace rvwo
