// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Test helpers: central-difference Jacobians and the relative error used by every Jacobian test.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "draw.h"

namespace rvwo::test {

// d f / d x at x by central differences; step h * max(1, |x_i|) per coordinate.
template <typename F>
Eigen::MatrixXd numericJacobian(F&& f, const Eigen::VectorXd& x, double h = 1e-6) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd J(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    const double step = h * std::max(1.0, std::fabs(x[i]));
    Eigen::VectorXd xp = x, xm = x;
    xp[i] += step;
    xm[i] -= step;
    J.col(i) = (f(xp) - f(xm)) / (2 * step);
  }
  return J;
}

// max |A - N| / max(max |N|, floor): the error relative to the Jacobian's own scale.
// A NaN or infinite entry anywhere gives +inf (std::max would otherwise drop a NaN silently).
inline double relativeError(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& numeric, double floor = 1e-12) {
  if (!analytic.allFinite() || !numeric.allFinite()) return std::numeric_limits<double>::infinity();
  const double scale = std::max(numeric.cwiseAbs().maxCoeff(), floor);
  return (analytic - numeric).cwiseAbs().maxCoeff() / scale;
}

// Random angle in (-pi, pi], with the hard cases over-represented: near +-pi and near 0.
inline double randomAngle(std::mt19937_64& rng, int i) {
  constexpr double kPi = 3.14159265358979323846;
  std::uniform_real_distribution<double> u(-kPi, kPi), tiny(-1e-7, 1e-7);
  switch (i % 5) {
    case 0:
      return kPi - std::fabs(tiny(rng));
    case 1:
      return -kPi + std::fabs(tiny(rng));
    case 2:
      return tiny(rng);
    default:
      return u(rng);
  }
}

// (x, y, theta): theta = randomAngle(rng, i), x and y from d; drawn theta, y, x (drawVector).
template <typename Distribution>
Eigen::Vector3d randomPose(Distribution& d, std::mt19937_64& rng, int i) {
  const double theta = randomAngle(rng, i);
  const Eigen::Vector2d xy = drawVector<2>(d, rng);
  return {xy.x(), xy.y(), theta};
}

}  // namespace rvwo::test
