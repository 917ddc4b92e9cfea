// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// SE(2): angle wrapping, group operations and their Jacobians near +-pi and at tiny angles,
// exp/log round trips, camera projections and the planar prior.
#include "rvwo/edges/se2.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "../common/numeric.h"
#include "rvwo/edges/camera.h"
#include "rvwo/edges/planar_prior.h"

namespace rvwo {
namespace {

using test::drawVector;
using test::numericJacobian;
using test::randomAngle;
using test::randomPose;
using test::relativeError;
constexpr double kPi = 3.14159265358979323846;

TEST(SE2, WrapAngle) {
  EXPECT_EQ(wrapAngle(kPi), kPi);
  EXPECT_EQ(wrapAngle(-kPi), kPi);  // (-pi, pi]
  EXPECT_EQ(wrapAngle(0.0), 0.0);
  EXPECT_NEAR(wrapAngle(3 * kPi), kPi, 1e-15);
  EXPECT_NEAR(wrapAngle(-3 * kPi + 0.1), -kPi + 0.1, 1e-14);
  EXPECT_NEAR(wrapAngle(2 * kPi + 1e-9), 1e-9, 1e-15);
  EXPECT_NEAR(wrapAngle(1e6), std::remainder(1e6, 2 * kPi), 1e-9);
  for (double a = -20; a < 20; a += 0.37) {
    const double w = wrapAngle(a);
    EXPECT_GT(w, -kPi);
    EXPECT_LE(w, kPi);
    EXPECT_NEAR(std::sin(w), std::sin(a), 1e-12);
    EXPECT_NEAR(std::cos(w), std::cos(a), 1e-12);
  }
}

// Differences of (x, y, theta) vectors with the angle wrapped, so that numeric Jacobians near
// +-pi do not see the 2 pi jump.
Eigen::VectorXd vec(const SE2& T, const SE2& ref) {
  Eigen::Vector3d v = T.vector();
  v.z() = ref.angle() + wrapAngle(T.angle() - ref.angle());
  return v;
}

TEST(SE2, GroupJacobiansAgainstNumeric) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-5, 5);
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    const SE2 a = SE2::fromVector(randomPose(u, rng, i)), b = SE2::fromVector(randomPose(u, rng, i + 2));
    Eigen::Matrix3d Ja, Jb, Ji, Jba, Jbb;
    const SE2 ab = a.compose(b, &Ja, &Jb);
    const SE2 ai = a.inverse(&Ji);
    const SE2 bt = a.between(b, &Jba, &Jbb);
    auto fa = [&](const Eigen::VectorXd& x) { return vec(SE2::fromVector(x).compose(b), ab); };
    auto fb = [&](const Eigen::VectorXd& x) { return vec(a.compose(SE2::fromVector(x)), ab); };
    auto fi = [&](const Eigen::VectorXd& x) { return vec(SE2::fromVector(x).inverse(), ai); };
    auto fba = [&](const Eigen::VectorXd& x) { return vec(SE2::fromVector(x).between(b), bt); };
    auto fbb = [&](const Eigen::VectorXd& x) { return vec(a.between(SE2::fromVector(x)), bt); };
    worst = std::max(
        {worst, relativeError(Ja, numericJacobian(fa, a.vector())), relativeError(Jb, numericJacobian(fb, b.vector())),
         relativeError(Ji, numericJacobian(fi, a.vector())), relativeError(Jba, numericJacobian(fba, a.vector())),
         relativeError(Jbb, numericJacobian(fbb, b.vector()))});
    Eigen::Matrix<double, 2, 3> Jp;
    Eigen::Matrix2d Jq;
    const Eigen::Vector2d q = drawVector<2>(u, rng);
    a.act(q, &Jp, &Jq);
    worst = std::max(
        {worst,
         relativeError(
             Jp, numericJacobian([&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return SE2::fromVector(x).act(q); },
                                 a.vector())),
         relativeError(Jq, numericJacobian([&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return a.act(x); }, q))});
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(SE2, ExpLogRoundTripAndGroupLaws) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 1000; ++i) {
    const SE2 T = SE2::fromVector(randomPose(u, rng, i));
    const SE2 back = SE2::exp(T.log());
    EXPECT_NEAR((back.translation() - T.translation()).norm(), 0.0, 1e-12) << T.angle();
    EXPECT_NEAR(wrapAngle(back.angle() - T.angle()), 0.0, 1e-15);
    const SE2 I = T * T.inverse();
    EXPECT_NEAR(I.translation().norm(), 0.0, 1e-12);
    EXPECT_NEAR(I.angle(), 0.0, 1e-15);
    // Constant-twist interpolation composes exactly: exp(f xi) exp((1 - f) xi) = exp(xi).
    const SE2 half = T.fraction(0.3) * T.fraction(0.7);
    EXPECT_NEAR((half.translation() - T.translation()).norm(), 0.0, 1e-12);
  }
  // Known values: a quarter circle of radius 1.
  const SE2 q = SE2::exp(Eigen::Vector3d(kPi / 2, 0, kPi / 2));
  EXPECT_NEAR(q.translation().x(), 1.0, 1e-15);
  EXPECT_NEAR(q.translation().y(), 1.0, 1e-15);
  // Tiny angles take the series branch without loss.
  const SE2 s = SE2::exp(Eigen::Vector3d(1.0, 0.0, 1e-9));
  EXPECT_NEAR(s.translation().y(), 0.5e-9, 1e-24);
}

TEST(SE2, Isometry3OnTheFloorActsAsThePlanarPose) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 100; ++i) {
    const SE2 T = SE2::fromVector(randomPose(u, rng, i)), U = SE2::fromVector(randomPose(u, rng, i + 1));
    const Eigen::Vector3d p = drawVector<3>(u, rng);
    const Eigen::Vector3d q = T.isometry3() * p;
    EXPECT_NEAR((q.head<2>() - T.act(p.head<2>())).norm(), 0.0, 1e-12);
    EXPECT_EQ(q.z(), p.z());  // the height is untouched
    // A group homomorphism: the lift of a product is the product of the lifts.
    EXPECT_NEAR(((T * U).isometry3().matrix() - (T.isometry3() * U.isometry3()).matrix()).norm(), 0.0, 1e-12);
  }
}

TEST(Camera, ProjectionJacobiansAndUnprojection) {
  const PinholeCamera pin(500, 505, 320, 240);
  // OpenLORIS-like T265 fisheye coefficients.
  const KannalaBrandtCamera kb(286.0, 286.5, 424.0, 400.0, -0.0105, 0.0463, -0.0431, 0.0079);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1), depth(0.3, 30);
  double worst = 0, worst_round = 0;
  for (int i = 0; i < 2000; ++i) {
    const double z = depth(rng);
    const Eigen::Vector2d uv = drawVector<2>(u, rng);
    Eigen::Vector3d P(uv.x() * z, uv.y() * z, z);
    if (i % 10 == 0) P.head<2>() *= 1e-7;    // near the optical axis: KB's series branch
    if (i % 10 == 1) P.head<2>().setZero();  // on it
    for (const CameraModel* cam : {static_cast<const CameraModel*>(&pin), static_cast<const CameraModel*>(&kb)}) {
      Eigen::Matrix<double, 2, 3> J;
      const Eigen::Vector2d uv = cam->project(P, &J);
      const Eigen::MatrixXd N =
          numericJacobian([&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return cam->project(x); }, P, 1e-7);
      worst = std::max(worst, relativeError(J, N));
      const Eigen::Vector3d ray = cam->unproject(uv);
      worst_round = std::max(worst_round, (ray.normalized() - P.normalized()).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(worst_round, 1e-9);
}

TEST(PlanarPrior, ResidualAndJacobian) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Isometry3d T_w_p = Eigen::Isometry3d::Identity();
  T_w_p.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T_w_p.translation() << 0.5, -1, 2;
  const PlanarPrior prior(T_w_p, 0.01, 0.02);
  // On the plane, any heading: zero residual.
  const Eigen::Isometry3d on = T_w_p * Eigen::Translation3d(3, 4, 0) * Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitZ());
  EXPECT_LT(prior.residual(on).norm(), 1e-14);
  double worst = 0;
  for (int i = 0; i < 500; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d axis = drawVector<3>(u, rng).normalized();
    T.linear() = Eigen::AngleAxisd(3 * u(rng), axis).toRotationMatrix();
    T.translation() << 5 * u(rng), 5 * u(rng), 5 * u(rng);
    Eigen::Matrix<double, 3, 6> J;
    prior.residual(T, &J);
    auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Eigen::Isometry3d Tp = T;
      const Eigen::Vector3d w = d.head<3>();
      Tp.linear() = T.linear() * (w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                               : Eigen::Matrix3d::Identity());
      Tp.translation() = T.translation() + T.linear() * d.tail<3>();
      return prior.residual(Tp);
    };
    worst = std::max(worst, relativeError(J, numericJacobian(f, Eigen::VectorXd::Zero(6))));
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_THROW(PlanarPrior(T_w_p, 0.0, 0.1), std::invalid_argument);
}

}  // namespace
}  // namespace rvwo
