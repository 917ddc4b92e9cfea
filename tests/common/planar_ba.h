// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// A small planar bundle adjustment shared by the solver tests: 6 robot poses along an arc, 300
// landmarks seen by a forward-looking monocular camera, wheel deltas between consecutive poses.
// Also computes the estimate's covariance independently of any solver (dense Gauss-Newton with
// the core Jacobians, first pose fixed), for the 3-sigma checks.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "cameras.h"
#include "draw.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_edge.h"

namespace rvwo::test {

// A forward-looking camera pitched down 0.1 rad, mounted 0.2 m ahead, 0.05 m left and 0.3 m up.
inline Eigen::Isometry3d forwardCamera() { return lookingAhead(0.1, Eigen::Vector3d(0.2, 0.05, 0.3)); }

struct Observation {
  int pose, point;
  Eigen::Vector2d z;
  Eigen::Matrix2d sqrt_information;
};

struct PlanarBA {
  PinholeCamera camera{450, 450, 320, 240};
  Eigen::Isometry3d T_b_c = forwardCamera();
  std::vector<Eigen::Vector3d> poses, points;  // truth
  std::vector<Observation> observations;
  std::vector<WheelDelta> wheel;  // between pose k and k + 1
  double sigma_px = 1.0;

  Se2XyzMonoEdge edge() const { return Se2XyzMonoEdge(camera, T_b_c); }

  // noisy = false: exact measurements (the solution is the truth); true: pixel and wheel noise.
  PlanarBA(bool noisy, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> g(0, 1);
    for (int k = 0; k < 6; ++k) poses.emplace_back(0.4 * k, 0.05 * k * k, 0.12 * k - 0.2);
    const Se2XyzMonoEdge e = edge();
    while (points.size() < 300) {
      // A point in front of a random pose, 2 to 10 m away, then kept if >= 3 poses see it.
      const Eigen::Vector3d& x = poses[static_cast<int>(u(rng) * 6)];
      const double depth = 2 + 8 * u(rng);
      const Eigen::Vector3d ray = camera.unproject(Eigen::Vector2d(640, 480).cwiseProduct(drawVector<2>(u, rng)));
      const Eigen::Isometry3d T_w_b =
          Eigen::Translation3d(x.x(), x.y(), 0) * Eigen::AngleAxisd(x.z(), Eigen::Vector3d::UnitZ());
      const Eigen::Vector3d P_w = T_w_b * T_b_c * (depth * ray);
      std::vector<Observation> seen;
      for (int k = 0; k < 6; ++k) {
        Eigen::Vector2d h;
        if (e.predict(poses[k], P_w, &h) && h.x() >= 0 && h.x() < 640 && h.y() >= 0 && h.y() < 480) {
          Eigen::Vector2d noise = Eigen::Vector2d::Zero();
          if (noisy) noise = sigma_px * drawVector<2>(g, rng);
          seen.push_back({k, static_cast<int>(points.size()), h + noise, Eigen::Matrix2d::Identity() / sigma_px});
        }
      }
      if (seen.size() < 3) continue;
      points.push_back(P_w);
      observations.insert(observations.end(), seen.begin(), seen.end());
    }
    for (int k = 0; k + 1 < 6; ++k) {
      const SE2 delta = SE2::fromVector(poses[k]).between(SE2::fromVector(poses[k + 1]));
      WheelDelta d;
      d.covariance = Eigen::Vector3d(0.02 * 0.02, 0.01 * 0.01, 0.01 * 0.01).asDiagonal();
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      if (noisy) n = Eigen::Vector3d(0.02, 0.01, 0.01).cwiseProduct(drawVector<3>(g, rng));
      d.dp = delta.translation() + n.head<2>();
      d.dphi = delta.angle() + n.z();
      wheel.push_back(d);
    }
  }

  // A perturbed start: poses 1..5 by ~0.1 m and ~0.03 rad, points by ~0.1 m (pose 0 is fixed).
  void perturbedStart(unsigned seed, std::vector<Eigen::Vector3d>* x, std::vector<Eigen::Vector3d>* p) const {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0, 1);
    *x = poses;
    *p = points;
    for (std::size_t k = 1; k < x->size(); ++k)
      (*x)[k] += Eigen::Vector3d(0.1, 0.1, 0.03).cwiseProduct(drawVector<3>(g, rng));
    for (auto& P : *p) P += 0.1 * drawVector<3>(g, rng);
  }

  // Errors of poses 1..5 against the truth (x, y, wrapped theta), stacked: 15 values.
  Eigen::VectorXd poseErrors(const std::vector<Eigen::Vector3d>& x) const {
    Eigen::VectorXd err(15);
    for (int k = 1; k < 6; ++k) {
      err.segment<3>(3 * (k - 1)) = x[k] - poses[k];
      err(3 * (k - 1) + 2) = wrapAngle(err(3 * (k - 1) + 2));
    }
    return err;
  }

  // Covariance of poses 1..5 (15 x 15) at the estimate, from the full Gauss-Newton information.
  Eigen::MatrixXd poseCovariance(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& p) const {
    const int np = 5 * 3, n = np + 3 * static_cast<int>(p.size());
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
    auto poseCol = [](int k) { return 3 * (k - 1); };  // pose 0 fixed: no columns
    const Se2XyzMonoEdge e = edge();
    for (const Observation& o : observations) {
      Eigen::Vector2d r;
      Se2XyzMonoEdge::Jacobian Jx, Jp;
      e.residual(x[o.pose], p[o.point], o.z, &r, &Jx, &Jp);
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2, n);
      if (o.pose > 0) J.block<2, 3>(0, poseCol(o.pose)) = o.sqrt_information * Jx;
      J.block<2, 3>(0, np + 3 * o.point) = o.sqrt_information * Jp;
      H += J.transpose() * J;
    }
    for (int k = 0; k + 1 < 6; ++k) {
      const WheelEdge w(wheel[k]);
      Eigen::Matrix3d Ji, Jj;
      w.residual(x[k], x[k + 1], &Ji, &Jj);
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3, n);
      if (k > 0) J.block<3, 3>(0, poseCol(k)) = w.sqrtInformation() * Ji;
      J.block<3, 3>(0, poseCol(k + 1)) = w.sqrtInformation() * Jj;
      H += J.transpose() * J;
    }
    const Eigen::MatrixXd cov = H.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
    return cov.topLeftCorner(np, np);
  }
};

}  // namespace rvwo::test
