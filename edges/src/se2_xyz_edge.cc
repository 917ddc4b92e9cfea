// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/edges/se2_xyz_edge.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

namespace rvwo {

double pyramidSigma(int level, double scale_factor) { return std::pow(scale_factor, level); }

template <int N>
Se2XyzEdge<N>::Se2XyzEdge(const CameraModel& camera, const Eigen::Isometry3d& T_b_c, double bf)
    : camera_(&camera), T_b_c_(T_b_c), bf_(bf) {
  const Eigen::Isometry3d T_c_b = T_b_c.inverse();
  R_c_b_ = T_c_b.linear();
  p_c_b_ = T_c_b.translation();
  if (N == 3 && !(bf > 0.0 && std::isfinite(bf))) {
    throw std::invalid_argument("Se2XyzStereoEdge: bf (baseline * fx) must be finite and > 0");
  }
  if (N == 3 && camera.kind() != CameraModel::Kind::kPinhole) {
    throw std::invalid_argument("Se2XyzStereoEdge: u_R = u_L - bf/z needs a rectified pinhole camera");
  }
}

template <int N>
bool Se2XyzEdge<N>::project(const Eigen::Vector3d& x_w_b, double c, double s, const Eigen::Vector3d& P_w, Vector* h,
                            Eigen::Matrix<double, N, 3>* dh_dPb, Eigen::Vector3d* P_b) const {
  const double dx = P_w.x() - x_w_b.x(), dy = P_w.y() - x_w_b.y();
  *P_b = Eigen::Vector3d(c * dx + s * dy, -s * dx + c * dy, P_w.z());  // eq. 8: R_w_b^T (P_w - p_w_b)
  const Eigen::Vector3d P_c = R_c_b_ * *P_b + p_c_b_;
  const double norm = P_c.norm();
  if (!(norm > 1e-9)) return false;
  if (camera_->kind() == CameraModel::Kind::kPinhole && !(P_c.z() > 1e-6 * norm)) return false;
  Eigen::Matrix<double, 2, 3> J_pi;
  const Eigen::Vector2d uv = camera_->project(P_c, dh_dPb ? &J_pi : nullptr);
  h->template head<2>() = uv;
  if constexpr (N == 3) {
    const double iz = 1.0 / P_c.z();
    (*h)(2) = uv.x() - bf_ * iz;
    if (dh_dPb) {
      Eigen::Matrix3d J3;
      J3.topRows<2>() = J_pi;
      J3.row(2) = J_pi.row(0);
      J3(2, 2) += bf_ * iz * iz;
      *dh_dPb = J3 * R_c_b_;
    }
  } else {
    if (dh_dPb) *dh_dPb = J_pi * R_c_b_;
  }
  return true;
}

template <int N>
bool Se2XyzEdge<N>::predict(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, Vector* h, Jacobian* J_pose,
                            Jacobian* J_point) const {
  Eigen::Matrix<double, N, 3> M;
  Eigen::Vector3d P_b;
  const bool need = J_pose || J_point;
  const double c = std::cos(x_w_b.z()), s = std::sin(x_w_b.z());
  if (!project(x_w_b, c, s, P_w, h, need ? &M : nullptr, &P_b)) return false;
  if (need) {
    Eigen::Matrix3d R_b_w;  // R_w_b^T
    R_b_w << c, s, 0, -s, c, 0, 0, 0, 1;
    if (J_point) *J_point = M * R_b_w;  // eq. 9
    if (J_pose) {
      J_pose->template leftCols<2>() = -M * R_b_w.leftCols<2>();
      J_pose->col(2) = M * Eigen::Vector3d(P_b.y(), -P_b.x(), 0.0);
    }
  }
  return true;
}

template <int N>
bool Se2XyzEdge<N>::residual(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, const Vector& z, Vector* r,
                             Jacobian* J_pose, Jacobian* J_point) const {
  if (!predict(x_w_b, P_w, r, J_pose, J_point)) return false;
  *r -= z;
  return true;
}

template <int N>
typename Se2XyzEdge<N>::Covariance Se2XyzEdge<N>::covariance(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w,
                                                             double sigma_px, const OutOfPlaneNoise& noise) const {
  Vector h;
  Eigen::Matrix<double, N, 3> M;
  Eigen::Vector3d P_b;
  if (!project(x_w_b, std::cos(x_w_b.z()), std::sin(x_w_b.z()), P_w, &h, &M, &P_b))
    return sigma_px * sigma_px * Covariance::Identity();
  return inflated(M, P_b, sigma_px, noise);
}

template <int N>
typename Se2XyzEdge<N>::Covariance Se2XyzEdge<N>::inflated(const Eigen::Matrix<double, N, 3>& M,
                                                           const Eigen::Vector3d& P_b, double sigma_px,
                                                           const OutOfPlaneNoise& noise) {
  Covariance cov = sigma_px * sigma_px * Covariance::Identity();
  // [P_b]x columns 0 and 1: d P_b / d(roll, pitch).
  Eigen::Matrix<double, 3, 2> dPb_drp;
  dPb_drp << 0.0, -P_b.z(), P_b.z(), 0.0, -P_b.y(), P_b.x();
  const Eigen::Matrix<double, N, 2> A = M * dPb_drp;
  const Vector b = -M.col(2);  // d P_b / d dz = -e_z
  cov += A * noise.sigma_rollpitch * A.transpose();
  cov += noise.sigma_z * noise.sigma_z * b * b.transpose();
  return cov;
}

template <int N>
typename Se2XyzEdge<N>::Covariance Se2XyzEdge<N>::sqrtInformation(const Eigen::Vector3d& x_w_b,
                                                                  const Eigen::Vector3d& P_w, double sigma_px,
                                                                  const OutOfPlaneNoise& noise) const {
  return whitener(covariance(x_w_b, P_w, sigma_px, noise));
}

template <int N>
typename Se2XyzEdge<N>::Covariance Se2XyzEdge<N>::whitener(const Covariance& cov) {
  const Eigen::LLT<Covariance> llt(cov);
  // Sigma = L L^T, so S = L^-1 whitens: S^T S = Sigma^-1.
  return llt.matrixL().solve(Covariance::Identity());
}

template <int N>
bool Se2XyzEdge<N>::whitening(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, const Vector& z,
                              double sigma_px, const OutOfPlaneNoise& noise, Vector* r, Covariance* S) const {
  Eigen::Matrix<double, N, 3> M;
  Eigen::Vector3d P_b;
  if (!project(x_w_b, std::cos(x_w_b.z()), std::sin(x_w_b.z()), P_w, r, &M, &P_b)) return false;
  *r -= z;
  *S = whitener(inflated(M, P_b, sigma_px, noise));
  return true;
}

template class Se2XyzEdge<2>;
template class Se2XyzEdge<3>;

}  // namespace rvwo
