// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// g2o edges over the core edges (rvwo/edges/...), analytic Jacobians from the core:
//   EdgeSE2XYZ<N>: g2o::VertexSE2 (robot pose) - g2o::VertexPointXYZ (landmark, world frame);
//                  measurement z (N = 2: u, v; N = 3: u_L, v, u_R); error h - z (eqs. 8 to 10).
//   EdgeSE2Wheel:  g2o::VertexSE2 i - g2o::VertexSE2 j; measurement the preintegrated
//                  (dp, dphi); error of eq. 14; information from the preintegration.
// VertexSE2 updates (x, y, theta) additively with the angle wrapped, which is the
// parameterisation the core Jacobians are written in.
#pragma once

#include <g2o/core/base_binary_edge.h>
#include <g2o/types/slam2d/vertex_se2.h>
#include <g2o/types/slam3d/vertex_pointxyz.h>

#include <Eigen/Core>
#include <iosfwd>

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

}  // namespace rvwo::g2o_adapters
