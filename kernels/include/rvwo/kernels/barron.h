// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Barron's general and adaptive robust loss (J. T. Barron, "A General and Adaptive Robust Loss
// Function", CVPR 2019), normalised as a solver kernel on the squared whitened error.
//
// Barron's loss of a residual x with shape alpha and scale c is
//
//   f(x, a, c) = |a-2|/a * [ ((x/c)^2/|a-2| + 1)^(a/2) - 1 ]
//
// RVWO paper eq. 3 prints (a - 2) where Barron has |a - 2|; for a > 2 the printed form changes
// the sign of the loss. We implement Barron's |a - 2| (see docs/maths.md, "Slips").
//
// Ceres (LossFunction::Evaluate) and g2o (RobustKernel::robustify) take s = x^2, the edge's
// chi2, and expect rho(0) = 0, rho'(0) = 1. So, with d = |a - 2| and z = s / (c^2 d):
//
//   rho(s)   = 2 c^2 f(sqrt(s), a, c) = 2 c^2 d / a * [ (1 + z)^(a/2) - 1 ]
//   rho'(s)  = (1 + z)^(a/2 - 1)                         IRLS weight; in (0, 1] for a <= 2
//   rho''(s) = sign(a - 2) / (2 c^2) * (1 + z)^(a/2 - 2)
//
// All derivatives are in s, not in x: the authors' code stored d rho / d x in rho[1], which g2o
// then used as d rho / d(x^2) (docs/maths.md, section 1).
//
// Special and limiting cases (evaluated in closed form, not through the general formula):
//   a = 2    : rho = s                                  (least squares)
//   a = 1    : rho = 2 c^2 (sqrt(1 + s/c^2) - 1)        (pseudo-Huber / Charbonnier)
//   a = 0    : rho = 2 c^2 log(1 + s/(2 c^2))           (Cauchy / Lorentzian)
//   a = -2   : rho = 2 c^2 * 2 s / (s + 4 c^2)          (Geman-McClure)
//   a = -inf : rho = 2 c^2 (1 - exp(-s/(2 c^2)))        (Welsch / Leclerc; the paper's "Tukey")
//   a = +inf : rho = 2 c^2 (exp(s/(2 c^2)) - 1)         (grows without bound; overflows to +inf)
//
// Values at s = 0, for every a: rho = 0, rho' = 1, rho'' = sign(a - 2)/(2 c^2) (0 at a = 2).
// Limits as s -> inf: for a < 0 rho tends to 2 c^2 d / |a| (bounded: gross outliers cost a
// constant and get zero weight); a = 0 grows as log s; 0 < a < 2 as s^(a/2); a = 2 as s.
//
// Numerics: the general formula is evaluated as 2 c^2 d / a * expm1(a/2 * log1p(z)), which keeps
// full relative precision near a = 0 (where a plain pow(...) - 1 loses every digit) and near
// a = 2 (where z is huge but log1p stays exact). Everything that depends on a alone is computed
// once in setAlpha(), so evaluate() is a branch and two or three elementary functions at most.
#pragma once

#include <limits>

namespace rvwo {

class BarronKernel {
 public:
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();

  // alpha: any value in [-inf, +inf] (NaN is rejected); c > 0, the scale in whitened units
  // (the paper uses c = 1). Throws std::invalid_argument on a NaN alpha or a c that is not
  // finite and positive.
  explicit BarronKernel(double alpha = 1.0, double c = 1.0);

  void setAlpha(double alpha);
  double alpha() const { return alpha_; }
  double c() const { return c_; }

  // s >= 0: squared whitened error (an edge's chi2). rho[0] = rho(s), rho[1] = d rho / ds,
  // rho[2] = d^2 rho / ds^2.
  void evaluate(double s, double rho[3]) const;

 private:
  enum class Branch { kGeneral, kTwo, kOne, kZero, kMinusTwo, kMinusInf, kPlusInf };
  double alpha_ = 1.0;
  double c_ = 1.0;
  Branch branch_ = Branch::kOne;
  // Constants of the current alpha and c (names follow the header's formulas).
  double inv_c2d_ = 1.0;   // 1 / (c^2 d)
  double scale_ = 2.0;     // 2 c^2 d / a
  double half_a_ = 0.5;    // a / 2
  double curv_ = -0.5;     // sign(a - 2) / (2 c^2)
  double inv_2c2_ = 0.5;   // 1 / (2 c^2)
  double two_c2_ = 2.0;    // 2 c^2
  bool near_two_ = false;  // |a - 2| < 0.25: rho' by its own exp (see evaluate)
};

}  // namespace rvwo

#include "rvwo/kernels/detail/barron_evaluate.h"
