// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// BarronKernel::evaluate, inline: a solver calls it once per residual and iteration, and through
// an adapter's virtual Evaluate an out-of-line call cost more than Ceres' own CauchyLoss
// (docs/decisions/0014). Included by rvwo/kernels/barron.h only.
#pragma once

#include <cmath>

namespace rvwo {

namespace barron_detail {

// From this z on, log(1 + z) is within 2^-53 / log(1 + z) < 4e-15 of log1p(z) (the rounding of
// 1 + z), and glibc's log costs less than its log1p.
constexpr double kLogOfSum = 1.0 / 32;

}  // namespace barron_detail

inline void BarronKernel::evaluate(double s, double rho[3]) const {
  switch (branch_) {
    case Branch::kTwo:
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    case Branch::kOne: {  // 2 c^2 (sqrt(1+z) - 1) written without cancellation
      const double z = s * inv_c2d_;
      const double r = std::sqrt(1.0 + z);
      const double q = 1.0 / (r * (r + 1.0));  // one division for both 1/r and 1/(r + 1)
      const double w = q * (r + 1.0);
      rho[0] = 2.0 * s * r * q;
      rho[1] = w;
      rho[2] = -inv_2c2_ * w * w * w;
      return;
    }
    case Branch::kZero: {  // log(1 + z) once 1 + z rounds off no digit of it that matters
      const double z = s * inv_c2d_;
      const double u = 1.0 + z;
      const double w = 1.0 / u;
      rho[0] = two_c2_ * (z < barron_detail::kLogOfSum ? std::log1p(z) : std::log(u));
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
