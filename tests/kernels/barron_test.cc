// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// BarronKernel: derivatives against central differences on every branch, closed forms at the
// limits, precision near alpha = 0 and 2 against long double, and the kernel's shape properties.
#include "rvwo/kernels/barron.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

namespace rvwo {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<double> alphaGrid() {
  return {-kInf, -1e3, -7.28, -2.0, -1.0, -1e-8, 0.0, 1e-8, 0.5, 1.0, 1.5, 2.0 - 1e-8, 2.0, 2.0 + 1e-8, 3.0, 4.0, kInf};
}
std::vector<double> sGrid() { return {0.0, 1e-6, 1e-3, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 100.0, 1e3, 1e4}; }

struct Rho {
  double v[3];
};
Rho eval(const BarronKernel& k, double s) {
  Rho r;
  k.evaluate(s, r.v);
  return r;
}

// d/ds of component i at s by central differences (second-order one-sided at s = 0), with the
// bound of its own round-off. The step follows the kernel's length scale in s, c^2 |a - 2|, which
// is tiny near a = 2: there the curvature changes over s ~ 1e-8 (see PreciseNearZeroAndTwo).
struct Numeric {
  double value, roundoff;
};
Numeric numericDerivative(const BarronKernel& k, double s, int i) {
  const double d = std::fabs(k.alpha() - 2.0);
  const double feature = (std::isfinite(d) && d > 0.0) ? std::min(1.0, k.c() * k.c() * d) : 1.0;
  const double h = 1e-5 * std::max(s, 1e-3 * feature);
  const double eps = std::numeric_limits<double>::epsilon();
  if (s < h) {
    const double f0 = eval(k, s).v[i], f1 = eval(k, s + h).v[i], f2 = eval(k, s + 2 * h).v[i];
    return {(-3.0 * f0 + 4.0 * f1 - f2) / (2 * h),
            8 * eps * (3 * std::fabs(f0) + 4 * std::fabs(f1) + std::fabs(f2)) / (2 * h)};
  }
  const double fp = eval(k, s + h).v[i], fm = eval(k, s - h).v[i];
  return {(fp - fm) / (2 * h), 8 * eps * (std::fabs(fp) + std::fabs(fm)) / (2 * h)};
}

TEST(BarronKernel, DerivativesMatchCentralDifferences) {
  for (double c : {1.0, 0.5, 3.0}) {
    for (double alpha : alphaGrid()) {
      const BarronKernel k(alpha, c);
      for (double s : sGrid()) {
        if (alpha == kInf && s / (2 * c * c) > 300) continue;  // exp overflows by design
        const Rho r = eval(k, s);
        const Numeric d1 = numericDerivative(k, s, 0), d2 = numericDerivative(k, s, 1);
        EXPECT_NEAR(d1.value, r.v[1], 1e-6 * std::fabs(r.v[1]) + d1.roundoff + 1e-12)
            << "rho' alpha=" << alpha << " c=" << c << " s=" << s;
        EXPECT_NEAR(d2.value, r.v[2], 1e-5 * std::fabs(r.v[2]) + d2.roundoff + 1e-12)
            << "rho'' alpha=" << alpha << " c=" << c << " s=" << s;
      }
    }
  }
}

TEST(BarronKernel, NormalisedAtZero) {
  for (double c : {1.0, 0.3}) {
    for (double alpha : alphaGrid()) {
      const Rho r = eval(BarronKernel(alpha, c), 0.0);
      EXPECT_EQ(r.v[0], 0.0) << alpha;
      EXPECT_EQ(r.v[1], 1.0) << alpha;
      const double curvature = alpha == 2.0 ? 0.0 : (alpha > 2.0 ? 1.0 : -1.0) / (2 * c * c);
      EXPECT_DOUBLE_EQ(r.v[2], curvature) << alpha;
    }
  }
}

// Closed forms written out in long double (so the reference does not lose digits itself).
TEST(BarronKernel, ClosedFormsAtTheLimits) {
  using L = long double;
  const L c = 0.7L, c2 = c * c;
  // exp(t) has condition number |t|: a one-ulp change of its argument moves it by |t| ulp.
  auto near = [&](double got, L want, const char* what, double s) {
    const double t = s / (2 * 0.49);
    EXPECT_NEAR(got, static_cast<double>(want), (1e-14 + 4e-16 * t) * std::fabs(static_cast<double>(want)) + 1e-300)
        << what << " s=" << s;
  };
  for (double s : sGrid()) {
    Rho r = eval(BarronKernel(2.0, 0.7), s);
    EXPECT_EQ(r.v[0], s);
    EXPECT_EQ(r.v[1], 1.0);
    EXPECT_EQ(r.v[2], 0.0);

    r = eval(BarronKernel(0.0, 0.7), s);  // Cauchy
    near(r.v[0], 2 * c2 * std::log1p(s / (2 * c2)), "a=0 rho", s);
    near(r.v[1], 1 / (s / (2 * c2) + 1), "a=0 rho'", s);
    near(r.v[2], -1 / ((s / (2 * c2) + 1) * (s / (2 * c2) + 1) * 2 * c2), "a=0 rho''", s);

    r = eval(BarronKernel(-kInf, 0.7), s);  // Welsch
    near(r.v[0], -2 * c2 * std::expm1(-s / (2 * c2)), "a=-inf rho", s);
    near(r.v[1], std::exp(-s / (2 * c2)), "a=-inf rho'", s);
    near(r.v[2], -std::exp(-s / (2 * c2)) / (2 * c2), "a=-inf rho''", s);

    r = eval(BarronKernel(1.0, 0.7), s);                              // pseudo-Huber
    near(r.v[0], 2 * s / (std::sqrt(1 + s / c2) + 1), "a=1 rho", s);  // = 2c^2 (sqrt(1+s/c^2) - 1)
    near(r.v[1], 1 / std::sqrt(1 + s / c2), "a=1 rho'", s);
    near(r.v[2], -1 / (2 * c2 * std::pow(1 + s / c2, 1.5L)), "a=1 rho''", s);

    r = eval(BarronKernel(-2.0, 0.7), s);  // Geman-McClure
    near(r.v[0], 2 * c2 * 2 * s / (s + 4 * c2), "a=-2 rho", s);
    near(r.v[1], 1 / ((1 + s / (4 * c2)) * (1 + s / (4 * c2))), "a=-2 rho'", s);
    near(r.v[2], -1 / (2 * c2 * std::pow(1 + s / (4 * c2), 3.0L)), "a=-2 rho''", s);

    if (s <= 100) {
      r = eval(BarronKernel(kInf, 0.7), s);
      near(r.v[0], 2 * c2 * std::expm1(s / (2 * c2)), "a=+inf rho", s);
      near(r.v[1], std::exp(s / (2 * c2)), "a=+inf rho'", s);
      near(r.v[2], std::exp(s / (2 * c2)) / (2 * c2), "a=+inf rho''", s);
    }
  }
}

// The general formula tends to each closed form: no branch is a discontinuity.
TEST(BarronKernel, GeneralFormulaTendsToTheClosedForms) {
  const struct {
    double special, near, tol;
  } cases[] = {{2.0, 2.0 - 1e-9, 1e-7}, {2.0, 2.0 + 1e-9, 1e-7},     {1.0, 1.0 + 1e-12, 1e-10}, {0.0, 1e-12, 1e-10},
               {0.0, -1e-12, 1e-10},    {-2.0, -2.0 + 1e-12, 1e-10}, {-kInf, -1e9, 1e-6},       {kInf, 1e9, 1e-6}};
  for (const auto& cs : cases) {
    for (double s : {1e-3, 0.5, 3.0, 20.0}) {
      const Rho a = eval(BarronKernel(cs.special), s), b = eval(BarronKernel(cs.near), s);
      for (int i = 0; i < 3; ++i) {
        // Near a = 2, rho'' = sign(a-2)/(2c^2) (1+z)^(a/2-2) ~ (a-2)/(2s) for z >> 1: it vanishes
        // only at that rate, so compare it with that leading term (relative error ~ 1/z).
        if (cs.special == 2.0 && i == 2) {
          const double lead = (cs.near - 2.0) / (2 * s);
          EXPECT_NEAR(b.v[i], lead, 1e-5 * std::fabs(lead)) << cs.near << " s=" << s;
          continue;
        }
        EXPECT_NEAR(b.v[i], a.v[i], cs.tol * (std::fabs(a.v[i]) + 1e-3)) << cs.near << " s=" << s << " i=" << i;
      }
    }
  }
}

// The same formula in long double (64-bit mantissa) as the reference.
void referenceLongDouble(long double s, long double a, long double c, long double out[3]) {
  const long double d = std::fabs(a - 2.0L), z = s / (c * c * d), l = std::log1p(z);
  out[0] = 2.0L * c * c * d / a * std::expm1(a / 2.0L * l);
  out[1] = std::exp((a / 2.0L - 1.0L) * l);
  out[2] = (a > 2.0L ? 1.0L : -1.0L) / (2.0L * c * c) * std::exp((a / 2.0L - 2.0L) * l);
}

TEST(BarronKernel, PreciseNearZeroAndTwo) {
  for (double centre : {0.0, 2.0}) {
    for (double offset : {1e-6, 1e-7, 1e-8, 1e-10, 1e-12, 1e-15}) {
      for (double sign : {-1.0, 1.0}) {
        const double alpha = centre + sign * offset;
        for (double c : {1.0, 2.5}) {
          const BarronKernel k(alpha, c);
          for (double s : sGrid()) {
            if (s == 0.0) continue;
            const Rho r = eval(k, s);
            long double ref[3];
            referenceLongDouble(s, alpha, c, ref);
            for (int i = 0; i < 3; ++i) {
              const double want = static_cast<double>(ref[i]);
              EXPECT_NEAR(r.v[i], want, 1e-10 * std::fabs(want)) << "alpha=" << alpha << " s=" << s << " i=" << i;
            }
          }
        }
      }
    }
  }
}

// The shapes Ceres also has (alpha = 0, Cauchy; alpha = 1, pseudo-Huber), whose evaluation is
// chosen by the size of s (issue #47): within 1e-13 of long double closed forms at every scale of
// s from 1e-300 to 1e12, and on both sides of where the Cauchy shape leaves log1p for log.
TEST(BarronKernel, CauchyAndPseudoHuberPreciseAtEveryScale) {
  using L = long double;
  for (const double c : {1.0, 0.7, 2.4}) {
    const L c2 = static_cast<L>(c) * c;
    std::vector<double> grid;
    for (int e = -6000; e <= 240; ++e) grid.push_back(std::pow(10.0, e / 20.0));
    const double edge = 2 * c * c / 32;  // the Cauchy shape's z = 1/32
    for (double s : {edge, edge * (1 - 1e-9), edge * (1 + 1e-9)})
      grid.insert(grid.end(), {std::nextafter(s, 0.0), s, std::nextafter(s, kInf)});
    const BarronKernel cauchy(0.0, c), pseudo_huber(1.0, c);
    double worst = 0, worst_s = 0;
    const char* worst_what = "";
    auto check = [&](double got, L want, const char* what, double s) {
      const double err = static_cast<double>(std::fabs((got - want) / want));
      if (err > worst) std::tie(worst, worst_s, worst_what) = std::make_tuple(err, s, what);
    };
    for (const double s : grid) {
      const L ls = s, zc = ls / (2 * c2), zh = ls / c2;
      Rho r = eval(cauchy, s);
      check(r.v[0], 2 * c2 * std::log1p(zc), "a=0 rho", s);
      check(r.v[1], 1 / (1 + zc), "a=0 rho'", s);
      check(r.v[2], -1 / (2 * c2 * (1 + zc) * (1 + zc)), "a=0 rho''", s);
      r = eval(pseudo_huber, s);
      check(r.v[0], 2 * ls / (std::sqrt(1 + zh) + 1), "a=1 rho", s);
      check(r.v[1], 1 / std::sqrt(1 + zh), "a=1 rho'", s);
      check(r.v[2], -1 / (2 * c2 * (1 + zh) * std::sqrt(1 + zh)), "a=1 rho''", s);
    }
    EXPECT_LE(worst, 1e-13) << worst_what << " c=" << c << " s=" << worst_s;
    // Far below the bar: the Cauchy shape's log(1 + z) at z = 1/32 is the worst (3.6e-15 at most,
    // barron.cc); an evaluation that lost digits near s = 0 would show here.
    EXPECT_LT(worst, 4e-15) << worst_what << " c=" << c << " s=" << worst_s;
  }
}

TEST(BarronKernel, WeightInUnitIntervalAndLossIncreasingInAlpha) {
  std::vector<double> alphas;
  for (double a : alphaGrid()) {
    if (a <= 2.0) alphas.push_back(a);
  }
  for (double s : sGrid()) {
    double previous = -1.0;
    for (double alpha : alphas) {
      const Rho r = eval(BarronKernel(alpha), s);
      EXPECT_LE(r.v[1], 1.0) << alpha << " " << s;
      EXPECT_GE(r.v[1], 0.0) << alpha << " " << s;
      if (s <= 1e3) {  // exp(-s/2) underflows past that
        EXPECT_GT(r.v[1], 0.0) << alpha << " " << s;
      }
      // Non-decreasing up to rounding: at tiny s neighbouring alphas agree to the last ulp (they
      // differ only at third order in s).
      EXPECT_GE(r.v[0], previous * (1 - 4 * std::numeric_limits<double>::epsilon()))
          << "rho not increasing in alpha at alpha=" << alpha << " s=" << s;
      previous = r.v[0];
    }
  }
}

TEST(BarronKernel, BoundedForNegativeAlpha) {
  for (double alpha : {-kInf, -1e3, -2.0, -0.5}) {
    const double bound = std::isinf(alpha) ? 2.0 : 2.0 * std::fabs(alpha - 2.0) / std::fabs(alpha);
    const Rho r = eval(BarronKernel(alpha), 1e12);
    EXPECT_LE(r.v[0], bound) << alpha;
    EXPECT_GT(r.v[0], 0.99 * bound) << alpha;
  }
}

TEST(BarronKernel, ScaleActsAsAUnit) {  // rho(s; a, c) = c^2 rho(s / c^2; a, 1)
  for (double alpha : alphaGrid()) {
    for (double s : {0.1, 2.0, 40.0}) {
      const double c = 1.7;
      const Rho a = eval(BarronKernel(alpha, c), s), b = eval(BarronKernel(alpha, 1.0), s / (c * c));
      EXPECT_NEAR(a.v[0], c * c * b.v[0], 1e-13 * std::fabs(a.v[0]));
      EXPECT_NEAR(a.v[1], b.v[1], 1e-13 * std::fabs(a.v[1]));
      EXPECT_NEAR(a.v[2], b.v[2] / (c * c), 1e-13 * std::fabs(a.v[2]) + 1e-300);
    }
  }
}

TEST(BarronKernel, AccessorsAndSetAlpha) {
  BarronKernel k(1.0, 2.0);
  EXPECT_EQ(k.alpha(), 1.0);
  EXPECT_EQ(k.c(), 2.0);
  k.setAlpha(-kInf);
  EXPECT_EQ(k.alpha(), -kInf);
  const Rho changed = eval(k, 3.0), fresh = eval(BarronKernel(-kInf, 2.0), 3.0);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(changed.v[i], fresh.v[i]);
}

TEST(BarronKernel, RejectsInvalidParameters) {
  EXPECT_THROW(BarronKernel(std::nan(""), 1.0), std::invalid_argument);
  EXPECT_THROW(BarronKernel(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(BarronKernel(1.0, -1.0), std::invalid_argument);
  EXPECT_THROW(BarronKernel(1.0, kInf), std::invalid_argument);
  BarronKernel k;
  EXPECT_THROW(k.setAlpha(std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace rvwo
