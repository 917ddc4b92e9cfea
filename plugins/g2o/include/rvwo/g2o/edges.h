// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// g2o edges over the core edges (rvwo/edges/...), analytic Jacobians from the core:
//   EdgeSE2XYZ<N>: g2o::VertexSE2 (robot pose) - g2o::VertexPointXYZ (landmark, world frame);
//                  measurement z (N = 2: u, v; N = 3: u_L, v, u_R); error h - z (eqs. 8 to 10).
//   EdgeSE2Wheel:  g2o::VertexSE2 i - g2o::VertexSE2 j; measurement the preintegrated
//                  (dp, dphi); error of eq. 14; information from the preintegration.
//   EdgePlanarPriorSE3: unary, on a g2o::VertexSE3Expmap (6-DoF hosts, ORB-SLAM style: the vertex
//                  holds T_x_w, world to its frame x, updated as exp(delta) * T, delta = (omega, v));
//                  holds the body near the floor plane (rvwo/edges/planar_prior.h).
// VertexSE2 updates (x, y, theta) additively with the angle wrapped, which is the
// parameterisation the core Jacobians are written in.
#pragma once

#include <g2o/core/base_binary_edge.h>
#include <g2o/core/base_unary_edge.h>
#include <g2o/types/sba/vertex_se3_expmap.h>
#include <g2o/types/slam2d/vertex_se2.h>
#include <g2o/types/slam3d/vertex_pointxyz.h>

#include <Eigen/Core>
#include <iosfwd>

#include "rvwo/edges/planar_prior.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_edge.h"

namespace rvwo::g2o_adapters {

template <int N>
class EdgeSE2XYZ final
    : public g2o::BaseBinaryEdge<N, Eigen::Matrix<double, N, 1>, g2o::VertexSE2, g2o::VertexPointXYZ> {
  using Base = g2o::BaseBinaryEdge<N, Eigen::Matrix<double, N, 1>, g2o::VertexSE2, g2o::VertexPointXYZ>;

 public:
  // The core edge (camera, extrinsic, stereo bf) is copied; its camera must outlive this edge.
  explicit EdgeSE2XYZ(const Se2XyzEdge<N>& core) : core_(core) {}
  // Sets the information to the inverse of the inflated covariance at the current estimates.
  void setInflatedInformation(double sigma_px, const OutOfPlaneNoise& noise);
  void computeError() override;
  using Base::linearizeOplus;  // keep g2o's linearizeOplus(JacobianWorkspace&) visible
  void linearizeOplus() override;
  // False when the landmark does not project (behind the camera) at the current estimates.
  bool isProjectable() const;

 private:
  Se2XyzEdge<N> core_;
};

class EdgeSE2Wheel final : public g2o::BaseBinaryEdge<3, Eigen::Vector3d, g2o::VertexSE2, g2o::VertexSE2> {
  using Base = g2o::BaseBinaryEdge<3, Eigen::Vector3d, g2o::VertexSE2, g2o::VertexSE2>;

 public:
  // Measurement (dp, dphi) and information from the preintegrated delta.
  explicit EdgeSE2Wheel(const WheelDelta& delta);
  void computeError() override;
  using Base::linearizeOplus;
  void linearizeOplus() override;

 private:
  WheelEdge core_;
};

class EdgePlanarPriorSE3 final : public g2o::BaseUnaryEdge<3, Eigen::Vector3d, g2o::VertexSE3Expmap> {
  using Base = g2o::BaseUnaryEdge<3, Eigen::Vector3d, g2o::VertexSE3Expmap>;

 public:
  // T_b_x: the vertex's frame x in the body frame (identity when the vertex is the body itself;
  // T_b_c when it is a camera, as in ORB-SLAM3). Information from the prior's sigmas.
  EdgePlanarPriorSE3(const PlanarPrior& prior, const Eigen::Isometry3d& T_b_x = Eigen::Isometry3d::Identity());
  void computeError() override;
  using Base::linearizeOplus;
  void linearizeOplus() override;

 private:
  Eigen::Isometry3d T_w_b() const;
  PlanarPrior prior_;
  Eigen::Isometry3d T_x_b_;
  Eigen::Matrix<double, 6, 6> minus_ad_;  // -Ad(T_b_x) in (omega, v) order
};

}  // namespace rvwo::g2o_adapters
