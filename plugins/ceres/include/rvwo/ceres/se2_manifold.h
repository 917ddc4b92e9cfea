// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The planar pose (x, y, theta) as a Ceres manifold, updated like g2o's VertexSE2:
// Plus(x, d) = (x + d0, y + d1, wrap(theta + d2)); Minus(y, x) = (y - x) with the angle wrapped.
// Both Jacobians are the identity, so the edges' Jacobians w.r.t. (x, y, theta) are the ones the
// solver uses, in Ceres and g2o alike.
#pragma once

#include <ceres/manifold.h>

#include "rvwo/edges/se2.h"

namespace rvwo::ceres_adapters {

class SE2Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 3; }
  int TangentSize() const override { return 3; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    x_plus_delta[0] = x[0] + delta[0];
    x_plus_delta[1] = x[1] + delta[1];
    x_plus_delta[2] = wrapAngle(x[2] + delta[2]);
    return true;
  }
  bool PlusJacobian(const double*, double* jacobian) const override {
    identity(jacobian);
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    y_minus_x[0] = y[0] - x[0];
    y_minus_x[1] = y[1] - x[1];
    y_minus_x[2] = wrapAngle(y[2] - x[2]);
    return true;
  }
  bool MinusJacobian(const double*, double* jacobian) const override {
    identity(jacobian);
    return true;
  }

 private:
  static void identity(double* j) {
    for (int i = 0; i < 9; ++i) j[i] = (i % 4 == 0) ? 1.0 : 0.0;
  }
};

}  // namespace rvwo::ceres_adapters
