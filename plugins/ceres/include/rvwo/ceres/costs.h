// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Ceres cost functions over the core edges (rvwo/edges/...), with analytic Jacobians from the
// core: residuals whitened by a square-root information S (S^T S = Sigma^-1).
//
//   Se2XyzCost<N>: blocks (x, y, theta)[3] and P_w[3]; residual S (h - z), N = 2 mono, 3 stereo.
//   WheelCost:     blocks (x, y, theta)_i[3] and (x, y, theta)_j[3]; residual S r (eq. 14).
//   WheelCalibratedCost: the same and the odometry's calibration c[3] (rvwo/edges/wheel_preintegration.h).
//
// Use SE2Manifold on the pose blocks. A projection that fails (point behind the camera) makes
// Evaluate return false, which Ceres treats as an infeasible step: do not add edges for points
// that are not in front of the camera at the start.
#pragma once

#include <ceres/problem.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <cmath>

#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_edge.h"

namespace rvwo::ceres_adapters {

template <int N>
class Se2XyzCost final : public ceres::SizedCostFunction<N, 3, 3> {
 public:
  using Vector = typename Se2XyzEdge<N>::Vector;
  using Matrix = Eigen::Matrix<double, N, N>;
  Se2XyzCost(const Se2XyzEdge<N>& edge, const Vector& z, const Matrix& sqrt_information)
      : edge_(edge), z_(z), sqrt_information_(sqrt_information) {}
  // The square-root information of the inflated covariance at a linearisation point (eq. 10),
  // computed once per problem set-up: the inflation depends on the point's position in the body.
  static Matrix sqrtInformation(const Se2XyzEdge<N>& edge, const Eigen::Vector3d& x_w_b, const Eigen::Vector3d& P_w,
                                double sigma_px, const OutOfPlaneNoise& noise);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Se2XyzEdge<N> edge_;
  Vector z_;
  Matrix sqrt_information_;
};

class WheelCost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  explicit WheelCost(const WheelEdge& edge) : edge_(edge) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  WheelEdge edge_;
};

class WheelCalibratedCost final : public ceres::SizedCostFunction<3, 3, 3, 3> {
 public:
  explicit WheelCalibratedCost(const WheelEdge& edge) : edge_(edge) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  WheelEdge edge_;
};

// The priors of the odometry's calibration c[3] (WheelCalibratedCost's third block) in one of a
// sequence of BAs, each refining what the ones before found (a recursive estimate):
//   - around the estimate before this BA (step: how far one BA may move it), in every BA;
//   - around zero (sigma: distance scale, turn scale, curvature in rad/m), in the first BA only
//     (first): the nominal wheels are prior knowledge, to be counted once. Added anew in every
//     BA it is counted once a window, and pulls the estimate towards zero by H / (H + 1/sigma^2)
//     (H: a window's information on c), for the rest of the run: the suite's turn scale settled
//     0.5-1 % short of its true correction (2 %), where a window with few turns has little H.
//     Beyond that, it is a bound: c stays within 3 sigma of zero in every BA.
void addWheelCalibrationPriors(ceres::Problem* problem, double* c, const Eigen::Vector3d& sigma,
                               const Eigen::Vector3d& step, const Eigen::Vector3d& c_before, bool first);

// The step of addWheelCalibrationPriors for a BA that comes dt seconds (of data: its newest
// keyframe's time) after the last one that refined c, when `step` is the step of BAs `period`
// seconds apart: step * sqrt(dt / period), dt taken within [0.01, 1] x period (NaN, no BA yet:
// the full step). The calibration drifts as a random walk in time (its variance grows with dt),
// not with the number of BAs: keyframes come at any rate, and walkers filling the view make one
// of nearly every frame. With a full step per BA, 30 BAs a second let c wander 15 times the
// variance a second that 2 do, each on a window of a quarter second that knows little of it: the
// suite's `dynamic` took the distance scale 0.7 % off in half a second as walkers came in. Above
// one period a BA keeps the full step (its window, not the time, then limits what it knows);
// below 0.01 a BA on the same keyframes as the last still has a tenth of it.
Eigen::Vector3d wheelCalibrationStep(const Eigen::Vector3d& step, double period, double dt);

// The information on the odometry's calibration c of one wheel edge between x_i and x_j, at c:
// J_c^T J_c of its whitened residual (WheelCalibratedCost's third block). The poses are taken
// as known: it is what the wheels say of c where vision has placed the keyframes.
Eigen::Matrix3d wheelCalibrationInformation(const WheelEdge& edge, const Eigen::Vector3d& x_i,
                                            const Eigen::Vector3d& x_j, const WheelCalibration& c);

// The odometry's calibration as a run of BAs refines it, kept by the host between them (under
// its own lock): the estimate, whether a BA has had it free yet (the prior around zero then
// counted), and the newest keyframe's time in the last BA that had it free (the random walk's
// clock). A BA copies it, starts its variable at c, adds addPriors, and calls refined() only if
// c was free in the solve it keeps (a BA that held c fixed has learnt nothing of it).
//
// Two ways to carry c from BA to BA:
//   - a walk (counting false): the prior around c is the step alone, so each BA moves c as far as
//     its window says. Stereo's scale wanders by a few tenths of a percent from window to window,
//     and c followed it: the wheels then held the map to vision's scale of the moment.
//   - counting: c is a constant, known better as the wheels run on (a recursive least squares).
//     The host passes refined() the information of the BA's priors (addPriors' return) plus that
//     of the wheel edges it brought in (wheelCalibrationInformation of the edges ending after t);
//     the prior around c is then the covariance so far plus the step, now the random walk of a
//     slow drift (tyres wearing), and the first BA has the prior around zero alone.
struct WheelCalibrationEstimate {
  WheelCalibration c = WheelCalibration::Zero();
  bool learnt = false;    // a BA has had c free: the prior around zero has been counted
  double t = NAN;         // s: the newest keyframe of the last BA that had c free (NaN: none yet)
  bool counting = false;  // see above; set by the host before the first BA
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of c when counting, once learnt

  // The step of a BA whose newest keyframe is at newest_t (wheelCalibrationStep, period in s).
  Eigen::Vector3d step(const Eigen::Vector3d& step_per_period, double period, double newest_t) const {
    return wheelCalibrationStep(step_per_period, period, newest_t - t);
  }
  // The priors on the BA's variable c_var (started at c) for a BA whose newest keyframe is at
  // newest_t: addWheelCalibrationPriors (around c with step(), around zero with sigma unless
  // learnt), or when counting, around zero with sigma in the first BA and around c with
  // covariance + step()^2 after it. Returns their information.
  Eigen::Matrix3d addPriors(ceres::Problem* problem, double* c_var, const Eigen::Vector3d& sigma,
                            const Eigen::Vector3d& step_per_period, double period, double newest_t) const;
  // A BA whose newest keyframe is at newest_t had c free and found c_new; information: what it
  // knew of c (counting: its priors' and its new wheel edges'; otherwise unused).
  void refined(const WheelCalibration& c_new, double newest_t,
               const Eigen::Matrix3d& information = Eigen::Matrix3d::Zero());
};

}  // namespace rvwo::ceres_adapters
