// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/g2o/edges.h"

#include <g2o/core/base_unary_edge.h>

#include <Eigen/Cholesky>

namespace rvwo::g2o_adapters {
namespace {

Eigen::Vector3d poseVector(const g2o::VertexSE2* v) { return v->estimate().toVector(); }

}  // namespace

template <int N>
void EdgeSE2XYZ<N>::setInflatedInformation(double sigma_px, const OutOfPlaneNoise& noise) {
  const auto cov = core_.covariance(poseVector(this->template vertexXnRaw<0>()),
                                    this->template vertexXnRaw<1>()->estimate(), sigma_px, noise);
  this->setInformation(cov.inverse());
}

template <int N>
void EdgeSE2XYZ<N>::computeError() {
  typename Se2XyzEdge<N>::Vector r;
  if (!core_.residual(poseVector(this->template vertexXnRaw<0>()), this->template vertexXnRaw<1>()->estimate(),
                      this->measurement_, &r)) {
    // Behind the camera: a large, finite error so the kernel rejects it rather than NaN the system.
    r.setConstant(1e4);
  }
  this->error_ = r;
}

template <int N>
void EdgeSE2XYZ<N>::linearizeOplus() {
  typename Se2XyzEdge<N>::Vector h;
  typename Se2XyzEdge<N>::Jacobian Jx, Jp;
  if (!core_.predict(poseVector(this->template vertexXnRaw<0>()), this->template vertexXnRaw<1>()->estimate(), &h, &Jx,
                     &Jp)) {
    Jx.setZero();
    Jp.setZero();
  }
  this->jacobianOplusXi_ = Jx;
  this->jacobianOplusXj_ = Jp;
}

template <int N>
bool EdgeSE2XYZ<N>::isProjectable() const {
  typename Se2XyzEdge<N>::Vector h;
  return core_.predict(poseVector(this->template vertexXnRaw<0>()), this->template vertexXnRaw<1>()->estimate(), &h);
}

template class EdgeSE2XYZ<2>;
template class EdgeSE2XYZ<3>;

EdgeSE2Wheel::EdgeSE2Wheel(const WheelDelta& delta) : core_(delta) {
  setMeasurement(Eigen::Vector3d(delta.dp.x(), delta.dp.y(), delta.dphi));
  setInformation(core_.information());
}

void EdgeSE2Wheel::computeError() {
  error_ = core_.residual(poseVector(vertexXnRaw<0>()), poseVector(vertexXnRaw<1>()));
}

void EdgeSE2Wheel::linearizeOplus() {
  Eigen::Matrix3d Ji, Jj;
  core_.residual(poseVector(vertexXnRaw<0>()), poseVector(vertexXnRaw<1>()), &Ji, &Jj);
  jacobianOplusXi_ = Ji;
  jacobianOplusXj_ = Jj;
}

EdgePlanarPriorSE3::EdgePlanarPriorSE3(const PlanarPrior& prior, const Eigen::Isometry3d& T_b_x)
    : prior_(prior), T_x_b_(T_b_x.inverse()) {
  setInformation(prior.information());
  setMeasurement(Eigen::Vector3d::Zero());
  // The vertex moves as T_x_w' = exp(d) T_x_w, so T_w_b' = T_w_b Exp(-Ad(T_b_x) d): a right
  // perturbation of T_w_b, which is what PlanarPrior differentiates by. Ad in (omega, v) order:
  // [[R, 0], [t^ R, R]].
  const Eigen::Matrix3d R = T_b_x.linear();
  const Eigen::Vector3d t = T_b_x.translation();
  Eigen::Matrix3d t_hat;
  t_hat << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  minus_ad_.setZero();
  minus_ad_.topLeftCorner<3, 3>() = -R;
  minus_ad_.bottomLeftCorner<3, 3>() = -t_hat * R;
  minus_ad_.bottomRightCorner<3, 3>() = -R;
}

Eigen::Isometry3d EdgePlanarPriorSE3::T_w_b() const {
  const Eigen::Isometry3d T_x_w(vertexXnRaw<0>()->estimate());
  return T_x_w.inverse() * T_x_b_;
}

void EdgePlanarPriorSE3::computeError() { error_ = prior_.residual(T_w_b()); }

void EdgePlanarPriorSE3::linearizeOplus() {
  Eigen::Matrix<double, 3, 6> J;
  prior_.residual(T_w_b(), &J);
  jacobianOplusXi_ = J * minus_ad_;
}

}  // namespace rvwo::g2o_adapters
