// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// g2o adapter of the adaptive Barron kernel (rvwo/kernels/barron.h). g2o calls robustify(chi2,
// rho) and scales the edge's information by rho[1] = d rho / d chi2, which is what BarronKernel
// returns (the authors' fork stored d rho / d e there, a wrong IRLS weight).
//
// Give each edge its own kernel to give each landmark its own alpha; setAlpha() between
// optimize() calls or iterations, never while g2o linearises. g2o's delta is not used: the scale
// is BarronKernel's c, fixed at construction.
#pragma once

#include <g2o/core/robust_kernel.h>

#include "rvwo/kernels/barron.h"

namespace rvwo::g2o_adapters {

class BarronRobustKernel final : public g2o::RobustKernel {
 public:
  explicit BarronRobustKernel(double alpha = 1.0, double c = 1.0) : kernel_(alpha, c) {}
  void robustify(double squared_error, g2o::Vector3& rho) const override {
    kernel_.evaluate(squared_error, rho.data());
  }
  void setAlpha(double alpha) { kernel_.setAlpha(alpha); }
  double alpha() const { return kernel_.alpha(); }
  double c() const { return kernel_.c(); }

 private:
  BarronKernel kernel_;
};

}  // namespace rvwo::g2o_adapters
