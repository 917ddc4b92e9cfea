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

void BarronKernel::evaluate(double s, double rho[3]) const {
  switch (branch_) {
    case Branch::kTwo:
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    case Branch::kOne: {  // 2 c^2 (sqrt(1+z) - 1) written without cancellation
      const double z = s * inv_c2d_;
      const double r = std::sqrt(1.0 + z);
      const double w = 1.0 / r;
      rho[0] = 2.0 * s / (r + 1.0);
      rho[1] = w;
      rho[2] = -inv_2c2_ * w * w * w;
      return;
    }
    case Branch::kZero: {
      const double z = s * inv_c2d_;
      const double w = 1.0 / (1.0 + z);
      rho[0] = two_c2_ * std::log1p(z);
      rho[1] = w;
      rho[2] = -inv_2c2_ * w * w;
      return;
    }
    case Branch::kMinusTwo: {
      const double z = s * inv_c2d_;
      const double w = 1.0 / (1.0 + z);
      rho[0] = 2.0 * two_c2_ * z * w;
      rho[1] = w * w;
      rho[2] = -inv_2c2_ * w * w * w;
      return;
    }
    case Branch::kMinusInf: {
      const double t = s * inv_2c2_;
      const double e = std::exp(-t);
      rho[0] = two_c2_ * (t < 0.5 ? -std::expm1(-t) : 1.0 - e);
      rho[1] = e;
      rho[2] = -inv_2c2_ * e;
      return;
    }
    case Branch::kPlusInf: {
      const double t = s * inv_2c2_;
      const double e = std::exp(t);
      rho[0] = two_c2_ * (t < 0.5 ? std::expm1(t) : e - 1.0);
      rho[1] = e;
      rho[2] = inv_2c2_ * e;
      return;
    }
    case Branch::kGeneral: {
      // Two elementary functions: L = log1p(z), then p = (1+z)^(a/2) = exp(a/2 L), through expm1
      // where p - 1 is small (a near 0 or s near 0) so that rho keeps its relative precision.
      const double z = s * inv_c2d_;
      const double l = std::log1p(z);
      const double x = half_a_ * l;
      double p, pm1;
      if (std::fabs(x) < 0.5) {
        pm1 = std::expm1(x);
        p = 1.0 + pm1;
      } else {
        p = std::exp(x);
        pm1 = p - 1.0;  // |p - 1| >= 1 - e^-0.5: no cancellation
      }
      const double inv_1pz = 1.0 / (1.0 + z);
      rho[0] = scale_ * pm1;
      // (1+z)^(a/2 - 1): as p / (1+z), except near a = 2, where z is huge, p / (1+z) would carry
      // |x| ulp of error and a third call keeps it to a few ulp (the adaptive model has a <= 1).
      rho[1] = near_two_ ? std::exp((half_a_ - 1.0) * l) : p * inv_1pz;
      rho[2] = curv_ * rho[1] * inv_1pz;  // sign(a-2)/(2c^2) (1+z)^(a/2 - 2)
      return;
    }
  }
}

}  // namespace rvwo
