// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Ceres adapter of the adaptive Barron kernel (rvwo/kernels/barron.h): rho(s), rho'(s), rho''(s)
// of the squared whitened residual s, exactly as BarronKernel computes them (the maths exists once).
//
// One BarronLoss per residual block lets each landmark carry its own alpha. setAlpha() may be
// called between solver iterations (from a ceres::IterationCallback, e.g. AlphaRefreshCallback
// below), never while Ceres evaluates: Evaluate() reads alpha without locking.
//
// alpha = -inf means "rejected": far from the solution its weight rho' = exp(-s/2c^2) is zero. A
// landmark held only by such residuals has a singular block in the Schur complement and can stall
// the trust region; take its residual blocks out of the problem (as ORB-SLAM does with outliers)
// or hold the point constant.
#pragma once

#include <ceres/iteration_callback.h>
#include <ceres/loss_function.h>

#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "rvwo/kernels/barron.h"

namespace rvwo::ceres_adapters {

class BarronLoss final : public ceres::LossFunction {
 public:
  explicit BarronLoss(double alpha = 1.0, double c = 1.0) : kernel_(alpha, c) {}
  void Evaluate(double s, double rho[3]) const override { kernel_.evaluate(s, rho); }
  void setAlpha(double alpha) { kernel_.setAlpha(alpha); }
  double alpha() const { return kernel_.alpha(); }
  double c() const { return kernel_.c(); }
  const BarronKernel& kernel() const { return kernel_; }

 private:
  BarronKernel kernel_;
};

// The loss of one reprojection residual in a planar BA: Huber at the root of the chi2 gate
// (ORB-SLAM's kernel), or the landmark's adaptive Barron kernel (eq. 7) of shape alpha and scale
// barron_scale times that root. The caller owns it (or hands it to a ceres::Problem).
inline ceres::LossFunction* reprojectionLoss(bool huber, double alpha, double barron_scale, double chi2_gate) {
  if (huber) return new ceres::HuberLoss(std::sqrt(chi2_gate));
  return new BarronLoss(alpha, barron_scale * std::sqrt(chi2_gate));
}

// Calls refresh(loss) for every registered loss at the end of each iteration, so that alphas
// follow the reliability model while the solver runs. Add it to Solver::Options::callbacks and
// set update_state_every_iteration = true when refresh reads the parameter blocks.
class AlphaRefreshCallback final : public ceres::IterationCallback {
 public:
  using Refresh = std::function<void(BarronLoss& loss, std::size_t index)>;
  AlphaRefreshCallback(std::vector<BarronLoss*> losses, Refresh refresh)
      : losses_(std::move(losses)), refresh_(std::move(refresh)) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    for (std::size_t i = 0; i < losses_.size(); ++i) refresh_(*losses_[i], i);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::vector<BarronLoss*> losses_;
  Refresh refresh_;
};

}  // namespace rvwo::ceres_adapters
