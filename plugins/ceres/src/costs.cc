// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/ceres/costs.h"

#include <ceres/normal_prior.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rvwo::ceres_adapters {

template <int N>
typename Se2XyzCost<N>::Matrix Se2XyzCost<N>::sqrtInformation(const Se2XyzEdge<N>& edge, const Eigen::Vector3d& x_w_b,
                                                              const Eigen::Vector3d& P_w, double sigma_px,
                                                              const OutOfPlaneNoise& noise) {
  return edge.sqrtInformation(x_w_b, P_w, sigma_px, noise);
}

template <int N>
bool Se2XyzCost<N>::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> x(parameters[0]), P(parameters[1]);
  Vector r;
  typename Se2XyzEdge<N>::Jacobian Jx, Jp;
  const bool want_x = jacobians && jacobians[0], want_p = jacobians && jacobians[1];
  if (!edge_.residual(x, P, z_, &r, want_x ? &Jx : nullptr, want_p ? &Jp : nullptr)) return false;
  Eigen::Map<Vector> res(residuals);
  res = sqrt_information_ * r;
  using RowMajor = Eigen::Matrix<double, N, 3, Eigen::RowMajor>;
  if (want_x) Eigen::Map<RowMajor>{jacobians[0]} = sqrt_information_ * Jx;
  if (want_p) Eigen::Map<RowMajor>{jacobians[1]} = sqrt_information_ * Jp;
  return true;
}

template class Se2XyzCost<2>;
template class Se2XyzCost<3>;

bool WheelCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> xi(parameters[0]), xj(parameters[1]);
  Eigen::Matrix3d Ji, Jj;
  const bool want_i = jacobians && jacobians[0], want_j = jacobians && jacobians[1];
  const Eigen::Vector3d r = edge_.residual(xi, xj, want_i ? &Ji : nullptr, want_j ? &Jj : nullptr);
  const Eigen::Matrix3d& S = edge_.sqrtInformation();
  Eigen::Map<Eigen::Vector3d> res(residuals);
  res = S * r;
  using RowMajor = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  if (want_i) Eigen::Map<RowMajor>{jacobians[0]} = S * Ji;
  if (want_j) Eigen::Map<RowMajor>{jacobians[1]} = S * Jj;
  return true;
}

bool WheelCalibratedCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> xi(parameters[0]), xj(parameters[1]), c(parameters[2]);
  Eigen::Matrix3d J[3];
  bool want[3];
  for (int k = 0; k < 3; ++k) want[k] = jacobians && jacobians[k];
  const Eigen::Vector3d r =
      edge_.residual(xi, xj, c, want[0] ? &J[0] : nullptr, want[1] ? &J[1] : nullptr, want[2] ? &J[2] : nullptr);
  const Eigen::Matrix3d& S = edge_.sqrtInformation();
  Eigen::Map<Eigen::Vector3d>{residuals} = S * r;
  using RowMajor = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  for (int k = 0; k < 3; ++k) {
    if (want[k]) Eigen::Map<RowMajor>{jacobians[k]} = S * J[k];
  }
  return true;
}

namespace {

// A Gaussian prior on c[3] of the given mean and information (SPD).
void addCalibrationPrior(ceres::Problem* problem, double* c, const Eigen::Vector3d& mean,
                         const Eigen::Matrix3d& information) {
  const Eigen::LLT<Eigen::Matrix3d> llt(information);
  if (llt.info() != Eigen::Success) throw std::invalid_argument("wheel calibration prior: information not SPD");
  // ||U (c - mean)||^2 = (c - mean)^T information (c - mean), U^T U = information.
  problem->AddResidualBlock(new ceres::NormalPrior(ceres::Matrix(llt.matrixU()), ceres::Vector(mean)), nullptr, c);
}

// c within 3 sigma of zero: the nominal wheels' prior, once counted, stays a bound.
void boundCalibration(ceres::Problem* problem, double* c, const Eigen::Vector3d& sigma,
                      const Eigen::Vector3d& c_before) {
  for (int i = 0; i < 3; ++i) {
    // Ceres refuses a start outside the bounds: never tighter than c_before (this BA's start).
    const double bound = std::max(3.0 * sigma[i], std::fabs(c_before[i]));
    problem->SetParameterLowerBound(c, i, -bound);
    problem->SetParameterUpperBound(c, i, bound);
  }
}

Eigen::Matrix3d diagonalInformation(const Eigen::Vector3d& sigma) {
  return sigma.array().square().inverse().matrix().asDiagonal();
}

}  // namespace

void addWheelCalibrationPriors(ceres::Problem* problem, double* c, const Eigen::Vector3d& sigma,
                               const Eigen::Vector3d& step, const Eigen::Vector3d& c_before, bool first) {
  // 1/sigma itself (not the root of an information): the estimator's figures stay as they were.
  if (first)
    problem->AddResidualBlock(new ceres::NormalPrior(ceres::Matrix(sigma.cwiseInverse().asDiagonal()),
                                                     ceres::Vector(Eigen::Vector3d::Zero())),
                              nullptr, c);
  problem->AddResidualBlock(
      new ceres::NormalPrior(ceres::Matrix(step.cwiseInverse().asDiagonal()), ceres::Vector(c_before)), nullptr, c);
  boundCalibration(problem, c, sigma, c_before);
}

Eigen::Matrix3d wheelCalibrationInformation(const WheelEdge& edge, const Eigen::Vector3d& x_i,
                                            const Eigen::Vector3d& x_j, const WheelCalibration& c) {
  Eigen::Matrix3d J_c;
  edge.residual(x_i, x_j, c, nullptr, nullptr, &J_c);
  const Eigen::Matrix3d SJ = edge.sqrtInformation() * J_c;
  return SJ.transpose() * SJ;
}

Eigen::Matrix3d WheelCalibrationEstimate::addPriors(ceres::Problem* problem, double* c_var,
                                                    const Eigen::Vector3d& sigma,
                                                    const Eigen::Vector3d& step_per_period, double period,
                                                    double newest_t) const {
  const Eigen::Vector3d s = step(step_per_period, period, newest_t);
  if (!counting) {
    addWheelCalibrationPriors(problem, c_var, sigma, s, c, !learnt);
    return learnt ? diagonalInformation(s) : Eigen::Matrix3d(diagonalInformation(sigma) + diagonalInformation(s));
  }
  Eigen::Matrix3d information;
  if (!learnt) {
    information = diagonalInformation(sigma);
    addCalibrationPrior(problem, c_var, Eigen::Vector3d::Zero(), information);
  } else {
    const Eigen::Matrix3d before = covariance + Eigen::Matrix3d(s.array().square().matrix().asDiagonal());
    information = before.inverse();
    addCalibrationPrior(problem, c_var, c, information);
  }
  boundCalibration(problem, c_var, sigma, c);
  return information;
}

void WheelCalibrationEstimate::refined(const WheelCalibration& c_new, double newest_t,
                                       const Eigen::Matrix3d& information) {
  c = c_new;
  learnt = true;
  t = newest_t;
  if (!counting) return;
  const Eigen::LLT<Eigen::Matrix3d> llt(information);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("WheelCalibrationEstimate::refined: counting needs an SPD information");
  covariance = llt.solve(Eigen::Matrix3d::Identity());
}

Eigen::Vector3d wheelCalibrationStep(const Eigen::Vector3d& step, double period, double dt) {
  if (!(period > 0)) throw std::invalid_argument("wheelCalibrationStep: period must be > 0");
  const double share = std::isnan(dt) ? 1.0 : std::clamp(dt / period, 0.01, 1.0);
  return step * std::sqrt(share);
}

}  // namespace rvwo::ceres_adapters
