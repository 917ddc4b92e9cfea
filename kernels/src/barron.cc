// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/kernels/barron.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rvwo {

BarronKernel::BarronKernel(double alpha, double c) {
  if (!(std::isfinite(c) && c > 0.0)) {
    throw std::invalid_argument("BarronKernel: scale c must be finite and > 0, got " + std::to_string(c));
  }
  c_ = c;
  inv_2c2_ = 0.5 / (c * c);
  two_c2_ = 2.0 * c * c;
  setAlpha(alpha);
}

void BarronKernel::setAlpha(double alpha) {
  if (std::isnan(alpha)) throw std::invalid_argument("BarronKernel: alpha is NaN");
  alpha_ = alpha;
  const double c2 = c_ * c_;
  if (alpha == 2.0) {
    branch_ = Branch::kTwo;
  } else if (alpha == 1.0) {
    branch_ = Branch::kOne;
    inv_c2d_ = 1.0 / c2;
  } else if (alpha == 0.0) {
    branch_ = Branch::kZero;
    inv_c2d_ = 1.0 / (2.0 * c2);
  } else if (alpha == -2.0) {
    branch_ = Branch::kMinusTwo;
    inv_c2d_ = 1.0 / (4.0 * c2);
  } else if (alpha == -kInfinity) {
    branch_ = Branch::kMinusInf;
  } else if (alpha == kInfinity) {
    branch_ = Branch::kPlusInf;
  } else {
    branch_ = Branch::kGeneral;
    const double d = std::fabs(alpha - 2.0);  // Barron's |a - 2| (paper eq. 3 prints a - 2)
    inv_c2d_ = 1.0 / (c2 * d);
    scale_ = 2.0 * c2 * d / alpha;
    half_a_ = 0.5 * alpha;
    curv_ = (alpha > 2.0 ? 1.0 : -1.0) * inv_2c2_;
    near_two_ = d < 0.25;
  }
}

}  // namespace rvwo
