// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// SE(2)-XYZ edge (eqs. 8 to 10): analytic Jacobians against central differences over 1000 random
// states per variant, the residual against an independent 3-D projection, and the out-of-plane
// covariance inflation against Monte Carlo.
#include "rvwo/edges/se2_xyz_edge.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <random>

#include "../common/numeric.h"
#include "../common/planar_ba.h"

namespace rvwo {
namespace {

using test::numericJacobian;
using test::randomAngle;
using test::relativeError;

// A world point seen by the camera at depth 0.3 to 30 m, within a 60-degree cone.
Eigen::Vector3d visiblePoint(std::mt19937_64& rng, const Eigen::Vector3d& x, const Eigen::Isometry3d& T_b_c) {
  std::uniform_real_distribution<double> depth(0.3, 30), u(-0.55, 0.55);
  const double z = depth(rng);
  const Eigen::Vector2d uv = test::drawVector<2>(u, rng);
  const Eigen::Vector3d P_c(uv.x() * z, uv.y() * z, z);
  const Eigen::Isometry3d T_w_b =
      Eigen::Translation3d(x.x(), x.y(), 0) * Eigen::AngleAxisd(x.z(), Eigen::Vector3d::UnitZ());
  return T_w_b * T_b_c * P_c;
}

// Independent reference: full 3-D pose, explicit transforms.
template <int N>
Eigen::Matrix<double, N, 1> reference(const CameraModel& cam, const Eigen::Isometry3d& T_b_c,
                                      const Eigen::Isometry3d& T_w_b, const Eigen::Vector3d& P_w, double bf) {
  const Eigen::Vector3d P_c = (T_w_b * T_b_c).inverse() * P_w;
  Eigen::Matrix<double, N, 1> h;
  h.template head<2>() = cam.project(P_c);
  if constexpr (N == 3) h(2) = h(0) - bf / P_c.z();
  return h;
}

template <int N>
void checkJacobians(const CameraModel& cam, double bf, unsigned seed) {
  const Eigen::Isometry3d T_b_c = test::forwardCamera();
  const Se2XyzEdge<N> edge(cam, T_b_c, bf);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-10, 10);
  double worst_pose = 0, worst_point = 0, worst_value = 0;
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d x = test::randomPose(u, rng, i);
    const Eigen::Vector3d P_w = visiblePoint(rng, x, T_b_c);
    typename Se2XyzEdge<N>::Vector z = Se2XyzEdge<N>::Vector::Random(), r;
    typename Se2XyzEdge<N>::Jacobian Jx, Jp;
    ASSERT_TRUE(edge.residual(x, P_w, z, &r, &Jx, &Jp));
    auto fx = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      typename Se2XyzEdge<N>::Vector out;
      edge.residual(v, P_w, z, &out);
      return out;
    };
    auto fp = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      typename Se2XyzEdge<N>::Vector out;
      edge.residual(x, v, z, &out);
      return out;
    };
    worst_pose = std::max(worst_pose, relativeError(Jx, numericJacobian(fx, x)));
    worst_point = std::max(worst_point, relativeError(Jp, numericJacobian(fp, P_w)));
    const Eigen::Isometry3d T_w_b =
        Eigen::Translation3d(x.x(), x.y(), 0) * Eigen::AngleAxisd(x.z(), Eigen::Vector3d::UnitZ());
    const auto want = reference<N>(cam, T_b_c, T_w_b, P_w, bf);
    worst_value = std::max(worst_value, (r + z - want).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst_pose, 1e-6);
  EXPECT_LT(worst_point, 1e-6);
  EXPECT_LT(worst_value, 1e-9);
  ::testing::Test::RecordProperty("worst_pose_relative_error", std::to_string(worst_pose));
}

TEST(Se2XyzEdge, MonoPinholeJacobians) { checkJacobians<2>(PinholeCamera(500, 500, 320, 240), 0.0, 10); }
TEST(Se2XyzEdge, MonoFisheyeJacobians) {
  checkJacobians<2>(KannalaBrandtCamera(286.0, 286.5, 424.0, 400.0, -0.0105, 0.0463, -0.0431, 0.0079), 0.0, 11);
}
TEST(Se2XyzEdge, StereoJacobians) { checkJacobians<3>(PinholeCamera(500, 500, 320, 240), 0.12 * 500, 12); }

TEST(Se2XyzEdge, RejectsPointsBehindAndBadStereo) {
  const PinholeCamera pin(500, 500, 320, 240);
  const Se2XyzMonoEdge edge(pin, test::forwardCamera());
  Eigen::Vector2d h;
  EXPECT_FALSE(edge.predict(Eigen::Vector3d::Zero(), Eigen::Vector3d(-5, 0, 0.3), &h));  // behind the robot
  EXPECT_TRUE(edge.predict(Eigen::Vector3d::Zero(), Eigen::Vector3d(5, 0, 0.3), &h));
  const KannalaBrandtCamera kb(286, 286, 424, 400, 0, 0, 0, 0);
  EXPECT_THROW(Se2XyzStereoEdge(kb, test::forwardCamera(), 30.0), std::invalid_argument);
  EXPECT_THROW(Se2XyzStereoEdge(pin, test::forwardCamera(), 0.0), std::invalid_argument);
  EXPECT_NEAR(pyramidSigma(0), 1.0, 0);
  EXPECT_NEAR(pyramidSigma(3), 1.728, 1e-12);
}

// Projections of the true 3-D pose, with random height, roll and pitch, scatter as the inflated
// covariance says (first order; small tilts).
template <int N>
void monteCarloInflation(unsigned seed) {
  const PinholeCamera pin(500, 500, 320, 240);
  const Eigen::Isometry3d T_b_c = test::forwardCamera();
  const Se2XyzEdge<N> edge(pin, T_b_c, 60.0);
  OutOfPlaneNoise noise;
  noise.sigma_z = 0.02;
  noise.sigma_rollpitch << 0.01 * 0.01, 0.3 * 0.01 * 0.015, 0.3 * 0.01 * 0.015, 0.015 * 0.015;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  const Eigen::Matrix2d L = noise.sigma_rollpitch.llt().matrixL();
  const Eigen::Vector3d x(1.0, -2.0, 0.7);
  for (const Eigen::Vector3d& P_c :
       {Eigen::Vector3d(0.4, -0.3, 2.0), Eigen::Vector3d(-1.0, 0.5, 6.0), Eigen::Vector3d(0.1, 0.2, 1.0)}) {
    const Eigen::Isometry3d T_w_b0 =
        Eigen::Translation3d(x.x(), x.y(), 0) * Eigen::AngleAxisd(x.z(), Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d P_w = T_w_b0 * T_b_c * P_c;
    typename Se2XyzEdge<N>::Vector h0;
    ASSERT_TRUE(edge.predict(x, P_w, &h0));
    const int kSamples = 5000;
    Eigen::Matrix<double, N, N> S = Eigen::Matrix<double, N, N>::Zero();
    Eigen::Matrix<double, N, 1> mean = Eigen::Matrix<double, N, 1>::Zero();
    std::vector<Eigen::Matrix<double, N, 1>> d(kSamples);
    for (int k = 0; k < kSamples; ++k) {
      const Eigen::Vector2d rp = L * test::drawVector<2>(g, rng);
      const double dz = noise.sigma_z * g(rng);
      const Eigen::Vector3d eta(rp.x(), rp.y(), 0.0);
      Eigen::Isometry3d T_w_b = T_w_b0;
      T_w_b.linear() = T_w_b0.linear() * Eigen::AngleAxisd(eta.norm(), eta.normalized()).toRotationMatrix();
      T_w_b.translation().z() = dz;
      d[k] = reference<N>(pin, T_b_c, T_w_b, P_w, 60.0) - h0;
      mean += d[k] / kSamples;
    }
    for (const auto& v : d) S += (v - mean) * (v - mean).transpose() / (kSamples - 1);
    const auto predicted = edge.covariance(x, P_w, 0.0, noise);
    const double rel = (S - predicted).norm() / predicted.norm();
    EXPECT_LT(rel, 0.10) << "P_c=" << P_c.transpose() << "\nsample\n" << S << "\npredicted\n" << predicted;
    // Pixel noise adds sigma^2 I on top.
    EXPECT_NEAR(
        (edge.covariance(x, P_w, 2.0, noise) - predicted - 4.0 * Eigen::Matrix<double, N, N>::Identity()).norm(), 0,
        1e-9);
    // The whitening factor: S^T S is the inverse covariance, and S is lower triangular (L^-1).
    const auto Si = edge.sqrtInformation(x, P_w, 2.0, noise);
    const auto cov = edge.covariance(x, P_w, 2.0, noise);
    EXPECT_LT((Si.transpose() * Si * cov - Eigen::Matrix<double, N, N>::Identity()).norm(), 1e-9);
    EXPECT_EQ(Si.template triangularView<Eigen::StrictlyUpper>().toDenseMatrix().norm(), 0.0);
  }
}

TEST(Se2XyzEdge, OutOfPlaneInflationMatchesMonteCarloMono) { monteCarloInflation<2>(20); }
TEST(Se2XyzEdge, OutOfPlaneInflationMatchesMonteCarloStereo) { monteCarloInflation<3>(21); }

// whitening() is residual() and sqrtInformation() at one point, bit for bit (the pose solver's
// rounds rely on it), and refuses what residual() refuses.
template <int N>
void checkWhitening(const CameraModel& cam, double bf, unsigned seed) {
  const Eigen::Isometry3d T_b_c = test::forwardCamera();
  const Se2XyzEdge<N> edge(cam, T_b_c, bf);
  OutOfPlaneNoise noise;
  noise.sigma_z = 0.01;
  noise.sigma_rollpitch << 1e-4, 2e-5, 2e-5, 2e-4;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-10, 10);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d x = test::randomPose(u, rng, i);
    const Eigen::Vector3d P_w = visiblePoint(rng, x, T_b_c);
    const typename Se2XyzEdge<N>::Vector z = Se2XyzEdge<N>::Vector::Random() * 300;
    typename Se2XyzEdge<N>::Vector r, r_want;
    typename Se2XyzEdge<N>::Covariance S;
    ASSERT_TRUE(edge.whitening(x, P_w, z, 1.44, noise, &r, &S));
    ASSERT_TRUE(edge.residual(x, P_w, z, &r_want));
    EXPECT_EQ(r, r_want);
    EXPECT_EQ(S, edge.sqrtInformation(x, P_w, 1.44, noise));
  }
  // A point behind the robot: a pinhole refuses it, a fisheye lens may see it; as residual() says.
  const Eigen::Vector3d behind(-5, 0, 0.3);
  typename Se2XyzEdge<N>::Vector r, r_want;
  typename Se2XyzEdge<N>::Covariance S;
  const bool projects = edge.residual(Eigen::Vector3d::Zero(), behind, Se2XyzEdge<N>::Vector::Zero(), &r_want);
  EXPECT_EQ(edge.whitening(Eigen::Vector3d::Zero(), behind, Se2XyzEdge<N>::Vector::Zero(), 1.0, noise, &r, &S),
            projects);
  if (cam.kind() == CameraModel::Kind::kPinhole) EXPECT_FALSE(projects);
}

TEST(Se2XyzEdge, WhiteningIsTheResidualAndTheSqrtInformation) {
  checkWhitening<2>(PinholeCamera(500, 500, 320, 240), 0.0, 30);
  checkWhitening<2>(KannalaBrandtCamera(286, 286, 424, 400, 0.01, -0.02, 0.003, -0.001), 0.0, 31);
  checkWhitening<3>(PinholeCamera(500, 500, 320, 240), 0.12 * 500, 32);
}

}  // namespace
}  // namespace rvwo
