// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/camera.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rvwo {

CameraModel::CameraModel(double fx, double fy, double cx, double cy) : fx_(fx), fy_(fy), cx_(cx), cy_(cy) {
  if (!(fx > 0 && fy > 0 && std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy))) {
    throw std::invalid_argument("camera: fx, fy must be finite and > 0, cx, cy finite");
  }
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& P_c, Eigen::Matrix<double, 2, 3>* J) const {
  const double iz = 1.0 / P_c.z();
  const double x = P_c.x() * iz, y = P_c.y() * iz;
  if (J) {
    *J << fx_ * iz, 0.0, -fx_ * x * iz, 0.0, fy_ * iz, -fy_ * y * iz;
  }
  return {fx_ * x + cx_, fy_ * y + cy_};
}

Eigen::Vector3d PinholeCamera::unproject(const Eigen::Vector2d& uv) const {
  return {(uv.x() - cx_) / fx_, (uv.y() - cy_) / fy_, 1.0};
}

KannalaBrandtCamera::KannalaBrandtCamera(double fx, double fy, double cx, double cy, double k1, double k2, double k3,
                                         double k4)
    : CameraModel(fx, fy, cx, cy), k_(k1, k2, k3, k4) {
  if (!k_.allFinite()) throw std::invalid_argument("camera: Kannala-Brandt coefficients must be finite");
}

Eigen::Vector2d KannalaBrandtCamera::project(const Eigen::Vector3d& P_c, Eigen::Matrix<double, 2, 3>* J) const {
  const double x = P_c.x(), y = P_c.y(), z = P_c.z();
  const double r2 = x * x + y * y, r = std::sqrt(r2);
  const double th = std::atan2(r, z), th2 = th * th;
  const double d = th * (1 + th2 * (k_[0] + th2 * (k_[1] + th2 * (k_[2] + th2 * k_[3]))));
  // psi = d / r, the radial scale; on the axis its limit is 1 / z.
  const double psi = r > 0.0 ? d / r : 1.0 / z;
  if (J) {
    const double rho2 = r2 + z * z;
    const double dd = 1 + th2 * (3 * k_[0] + th2 * (5 * k_[1] + th2 * (7 * k_[2] + th2 * 9 * k_[3])));
    // d psi / d(x, y) = (x, y) * g with g = (d' z / rho^2 - d / r) / r^2. The bracket cancels near
    // the axis, where its series in theta is used: (d' cos sin - d) / (rho sin^3) over rho^2, with
    // d' cos sin - d = theta^3 (2 k1 - 2/3) + theta^5 (2/15 - 2 k1 + 4 k2) + O(theta^7).
    double g;
    if (th < 1e-3) {
      const double rho = std::sqrt(rho2), s = std::sin(th);
      const double num = th2 * th * ((2 * k_[0] - 2.0 / 3.0) + th2 * (2.0 / 15.0 - 2 * k_[0] + 4 * k_[1]));
      g = s > 0.0 ? num / (rho2 * rho * s * s * s) : (2 * k_[0] - 2.0 / 3.0) / (z * z * z);
    } else {
      g = (dd * z / rho2 - d / r) / r2;
    }
    const double dpsi_dz = -dd / rho2;
    *J << fx_ * (psi + x * x * g), fx_ * x * y * g, fx_ * x * dpsi_dz,  //
        fy_ * x * y * g, fy_ * (psi + y * y * g), fy_ * y * dpsi_dz;
  }
  return {fx_ * psi * x + cx_, fy_ * psi * y + cy_};
}

Eigen::Vector3d KannalaBrandtCamera::unproject(const Eigen::Vector2d& uv) const {
  const double mx = (uv.x() - cx_) / fx_, my = (uv.y() - cy_) / fy_;
  const double rd = std::sqrt(mx * mx + my * my);
  if (rd < 1e-15) return {0.0, 0.0, 1.0};
  // Newton on d(theta) = rd, from theta = rd.
  double th = rd;
  for (int i = 0; i < 20; ++i) {
    const double th2 = th * th;
    const double d = th * (1 + th2 * (k_[0] + th2 * (k_[1] + th2 * (k_[2] + th2 * k_[3])))) - rd;
    const double dd = 1 + th2 * (3 * k_[0] + th2 * (5 * k_[1] + th2 * (7 * k_[2] + th2 * 9 * k_[3])));
    const double step = d / dd;
    th -= step;
    if (std::fabs(step) < 1e-14) break;
  }
  const double s = std::sin(th) / rd;
  return {mx * s, my * s, std::cos(th)};
}

}  // namespace rvwo
