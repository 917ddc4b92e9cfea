// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/spatial_pose.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "robust_weight.h"

namespace rvwo {
namespace {

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

// T_c_w after the step (omega, v): the rotation Exp(omega) applied on the camera's side.
Eigen::Isometry3d stepped(const Eigen::Isometry3d& T, const Eigen::Matrix<double, 6, 1>& d) {
  const Eigen::Vector3d w = d.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d R =
      angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = R * T.linear();
  out.translation() = R * T.translation() + d.tail<3>();
  return out;
}

}  // namespace

bool spatialResidual(const CameraModel& camera, double bf, const PoseObservation& o, const Eigen::Isometry3d& T_c_w,
                     Eigen::Vector3d* r, Eigen::Matrix<double, 3, 6>* J) {
  const Eigen::Vector3d P_c = T_c_w * o.P_w;
  if (camera.kind() == CameraModel::Kind::kPinhole && P_c.z() <= 1e-6) return false;
  Eigen::Matrix<double, 2, 3> Jp;
  const Eigen::Vector2d uv = camera.project(P_c, J ? &Jp : nullptr);
  const double s = 1.0 / o.sigma_px;
  r->head<2>() = s * (o.z.head<2>() - uv);
  (*r)(2) = 0;
  // d P_c / d(omega, v) = [-[P_c]x, I]; the residual is minus the projection's change.
  Eigen::Matrix<double, 3, 3> Jz = Eigen::Matrix3d::Zero();  // d(u, v, u_R) / d P_c
  if (J) Jz.topRows<2>() = Jp;
  if (o.stereo) {
    if (!(bf > 0)) throw std::invalid_argument("optimiseSpatialPose: a stereo observation without a baseline");
    (*r)(2) = s * (o.z.z() - (uv.x() - bf / P_c.z()));
    if (J) Jz.row(2) = Jp.row(0) + Eigen::RowVector3d(0, 0, bf / (P_c.z() * P_c.z()));
  }
  if (J) {
    Eigen::Matrix<double, 3, 6> dP;
    dP << -hat(P_c), Eigen::Matrix3d::Identity();
    *J = -s * Jz * dP;
    if (!o.stereo) J->row(2).setZero();
  }
  return true;
}

SpatialPoseResult optimiseSpatialPose(const CameraModel& camera, double bf, const std::vector<PoseObservation>& obs,
                                      const SpatialPoseOptions& opt, Eigen::Isometry3d* T_c_w) {
  const std::size_t n = obs.size();
  SpatialPoseResult out;
  out.inlier.resize(n);
  out.error.assign(n, 0.0);
  std::vector<char> usable(n);
  std::vector<BarronKernel> kernel;  // per match, made once (its constants depend on alpha alone)
  kernel.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    usable[k] = tracking_detail::placesThePose(obs[k], opt.huber);
    out.inlier[k] = obs[k].first_round;
    kernel.emplace_back(obs[k].alpha, std::sqrt(chi2Gate(obs[k].stereo)) * opt.barron_scale);
  }
  for (int round = 0; round < opt.rounds; ++round) {
    for (int it = 0; it < opt.iterations; ++it) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      for (std::size_t k = 0; k < n; ++k) {
        if (!usable[k] || !out.inlier[k]) continue;
        Eigen::Vector3d r;
        Eigen::Matrix<double, 3, 6> J;
        if (!spatialResidual(camera, bf, obs[k], *T_c_w, &r, &J)) {
          out.inlier[k] = 0;
          continue;
        }
        const double w = tracking_detail::weight(r.squaredNorm(), kernel[k], opt.huber, obs[k].stereo);
        H += w * J.transpose() * J;
        g += w * J.transpose() * r;
      }
      H.diagonal().array() += 1e-9;  // no match: a zero step rather than NaN
      const Eigen::Matrix<double, 6, 1> d = -H.ldlt().solve(g);
      if (!d.allFinite()) break;
      *T_c_w = stepped(*T_c_w, d);
      if (d.tail<3>().norm() < 1e-6 && d.head<3>().norm() < 1e-7) break;
    }
    // Classify against the gate (every match, so that a rejected one may come back).
    out.inliers = 0;
    for (std::size_t k = 0; k < n; ++k) {
      Eigen::Vector3d r;
      const double e2 = spatialResidual(camera, bf, obs[k], *T_c_w, &r) ? r.squaredNorm() : 1e9;
      out.error[k] = std::sqrt(e2);
      out.inlier[k] = usable[k] && e2 <= chi2Gate(obs[k].stereo);
      out.inliers += out.inlier[k];
    }
  }
  return out;
}

}  // namespace rvwo
