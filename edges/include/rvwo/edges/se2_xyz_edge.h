// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// SE(2)-XYZ visual edge (RVWO paper eqs. 8 to 10; Zheng & Liu, ICRA 2019): a landmark P_w seen
// from a robot whose pose is planar, x_w_b = (x, y, theta), through the body-to-camera
// extrinsic T_b_c:
//
//   P_b = R_w_b^T (P_w - p_w_b),   R_w_b = Rz(theta), p_w_b = (x, y, 0)
//   P_c = R_c_b P_b + p_c_b,       T_c_b = T_b_c^-1
//   h   = pi(P_c)  (mono: u, v)   or   (u_L, v, u_L - bf / z_c)  (stereo; RGB-D as virtual stereo)
//   r   = h - z
//
// Jacobians: dP_b/d(x, y) = -R_w_b^T [e_x e_y], dP_b/dtheta = (P_b.y, -P_b.x, 0), dP_b/dP_w = R_w_b^T,
// each chained with d h / d P_c * R_c_b.
//
// The robot is not exactly planar (floor bumps, suspension): its true pose is
// R = Rz(theta) Exp((roll, pitch, 0)), p = (x, y, dz). To first order, dP_b/d(roll, pitch) =
// [P_b]x[:, 0:2] and dP_b/d dz = -e_z, so the residual's covariance is inflated to
//   Sigma_r = sigma_px^2 I + A Sigma_rp A^T + sigma_z^2 b b^T,
//   A = dh/dP_c R_c_b [P_b]x[:, 0:2],   b = -dh/dP_c R_c_b e_z     (docs/maths.md section 3)
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rvwo/edges/camera.h"

namespace rvwo {

// Motion out of the plane that the SE(2) state ignores.
struct OutOfPlaneNoise {
  double sigma_z = 0.0;                                       // m: std of the body's height
  Eigen::Matrix2d sigma_rollpitch = Eigen::Matrix2d::Zero();  // rad^2: covariance of (roll, pitch)
};

// Keypoint noise of pyramid level `level`: scale_factor^level px (ORB-SLAM3, 1.2 per level).
double pyramidSigma(int level, double scale_factor = 1.2);

// N = 2: monocular (u, v). N = 3: rectified stereo or RGB-D (u_L, v, u_R).
template <int N>
class Se2XyzEdge {
  static_assert(N == 2 || N == 3, "Se2XyzEdge: N is 2 (mono) or 3 (stereo)");

 public:
  using Vector = Eigen::Matrix<double, N, 1>;
  using Jacobian = Eigen::Matrix<double, N, 3>;
  using Covariance = Eigen::Matrix<double, N, N>;

  // camera: shared by many edges, must outlive them. T_b_c: the camera's pose in the body frame.
  // bf: stereo baseline times fx (px m), N = 3 only; stereo needs a pinhole (rectified) camera.
  Se2XyzEdge(const CameraModel& camera, const Eigen::Isometry3d& T_b_c, double bf = 0.0);

  // Predicted measurement h(x_w_b, P_w) and its Jacobians w.r.t. (x, y, theta) and P_w. False
  // when the point cannot be projected (behind a pinhole camera, or at the camera centre); the
  // outputs are then left unspecified.
  bool predict(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, Vector* h, Jacobian* J_pose = nullptr,
               Jacobian* J_point = nullptr) const;
  // r = h - z, with the Jacobians of h.
  bool residual(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, const Vector& z, Vector* r,
                Jacobian* J_pose = nullptr, Jacobian* J_point = nullptr) const;
  // Sigma_r, the measurement covariance inflated by the out-of-plane motion (eq. 10).
  Covariance covariance(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, double sigma_px,
                        const OutOfPlaneNoise& noise) const;
  // S with S^T S = covariance()^-1 (S = L^-1 of its Cholesky factor): S r is the whitened residual.
  Covariance sqrtInformation(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, double sigma_px,
                             const OutOfPlaneNoise& noise) const;

  // residual() and sqrtInformation() at one point, from one projection. False when the point
  // cannot be projected (r and S are then left unspecified).
  bool whitening(const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w, const Vector& z, double sigma_px,
                 const OutOfPlaneNoise& noise, Vector* r, Covariance* S) const;

  const CameraModel& camera() const { return *camera_; }
  const Eigen::Isometry3d& T_b_c() const { return T_b_c_; }

 private:
  // h, dh/dP_b and P_b; c, s: cos and sin of x_w_b's heading (computed once by the caller).
  bool project(const Eigen::Vector3d& x_w_b, double c, double s, const Eigen::Vector3d& P_w, Vector* h,
               Eigen::Matrix<double, N, 3>* dh_dPb, Eigen::Vector3d* P_b) const;
  // covariance() from the projection's dh/dP_b and P_b.
  static Covariance inflated(const Eigen::Matrix<double, N, 3>& M, const Eigen::Vector3d& P_b, double sigma_px,
                             const OutOfPlaneNoise& noise);
  static Covariance whitener(const Covariance& cov);  // L^-1 of cov = L L^T
  const CameraModel* camera_;
  Eigen::Isometry3d T_b_c_;
  Eigen::Matrix3d R_c_b_;
  Eigen::Vector3d p_c_b_;
  double bf_;
};

using Se2XyzMonoEdge = Se2XyzEdge<2>;
using Se2XyzStereoEdge = Se2XyzEdge<3>;

}  // namespace rvwo
