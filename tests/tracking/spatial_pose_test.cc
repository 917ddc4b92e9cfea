// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// optimiseSpatialPose: its residual's Jacobian against central differences (pinhole mono and
// stereo, Kannala-Brandt); it recovers a known 6-DoF pose from noisy matches with gross outliers;
// its estimate is a stationary point of the robust cost; rejected (alpha -inf) and unusable
// matches never move the pose, even when they agree on another one (a walker).
#include "rvwo/tracking/spatial_pose.h"

#include <gtest/gtest.h>

#include <random>

#include "../common/numeric.h"
#include "gate_checks.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/kernels/barron.h"

namespace rvwo {
namespace {

Eigen::Isometry3d pose(const Eigen::Vector3d& rotation_vector, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (rotation_vector.norm() > 0)
    T.linear() = Eigen::AngleAxisd(rotation_vector.norm(), rotation_vector.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

struct Scene {
  PinholeCamera camera{400, 400, 319.5, 239.5};
  double bf = 0.12 * 400;
  Eigen::Isometry3d T_c_w = pose(Eigen::Vector3d(0.3, -1.2, 0.4), Eigen::Vector3d(0.5, -0.2, 1.5));
  std::vector<PoseObservation> obs;
  std::vector<char> is_outlier;

  // n matches: every third mono, the rest stereo; noise 1 px at level 0 (pyramidSigma); a fraction
  // `outliers` moved 20 to 60 px off with a consistent disparity.
  Scene(int n, double outliers, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), depth(1.0, 10.0), off(20, 60), coin(0, 1);
    std::normal_distribution<double> g(0, 1);
    while (static_cast<int>(obs.size()) < n) {
      const double z = depth(rng);
      const Eigen::Vector3d P_c(u(rng) * 0.7 * z, u(rng) * 0.5 * z, z);
      PoseObservation o;
      o.P_w = T_c_w.inverse() * P_c;
      o.stereo = obs.size() % 3 != 0;
      o.sigma_px = pyramidSigma(static_cast<int>(obs.size() % 4));
      const Eigen::Vector2d uv = camera.project(P_c);
      const Eigen::Vector3d h(uv.x(), uv.y(), uv.x() - bf / z);
      o.z = h + o.sigma_px * Eigen::Vector3d(g(rng), g(rng), g(rng));
      const bool bad = coin(rng) < outliers;
      if (bad) {
        const double a = 3.14159265358979 * u(rng);
        o.z.head<2>() += off(rng) * Eigen::Vector2d(std::cos(a), std::sin(a));
        o.z.z() = o.z.x() - (h.x() - h.z());
      }
      obs.push_back(o);
      is_outlier.push_back(bad);
    }
  }
};

double rotationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

Eigen::Isometry3d steppedBy(const Eigen::Isometry3d& T, const Eigen::VectorXd& d) {
  Eigen::Isometry3d out = pose(d.head<3>(), Eigen::Vector3d::Zero()) * T;
  out.translation() += d.tail<3>();
  return out;
}

TEST(SpatialPose, ResidualJacobianMatchesCentralDifferences) {
  const PinholeCamera pinhole(420, 410, 320, 240);
  const KannalaBrandtCamera fisheye(285, 286, 424, 400, -0.008, 0.043, -0.040, 0.007);
  const Eigen::Isometry3d T = pose(Eigen::Vector3d(0.2, 0.5, -0.1), Eigen::Vector3d(0.3, 0.1, -0.4));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 30; ++i) {
    const CameraModel& camera = i % 3 == 2 ? static_cast<const CameraModel&>(fisheye) : pinhole;
    PoseObservation o;
    const Eigen::Vector3d P_c(u(rng), 0.6 * u(rng), 2.5 + u(rng));
    o.P_w = T.inverse() * P_c;
    o.stereo = i % 3 == 0;
    o.sigma_px = 1.2 + 0.1 * i;
    o.z = Eigen::Vector3d(300 + 10 * u(rng), 250 + 10 * u(rng), 280);
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> J;
    ASSERT_TRUE(spatialResidual(camera, 50.0, o, T, &r, &J));
    auto f = [&](const Eigen::VectorXd& d) {
      Eigen::Vector3d rd;
      EXPECT_TRUE(spatialResidual(camera, 50.0, o, steppedBy(T, d), &rd));
      return Eigen::VectorXd(rd);
    };
    const Eigen::MatrixXd numeric = test::numericJacobian(f, Eigen::VectorXd::Zero(6));
    EXPECT_LT(test::relativeError(J, numeric), 1e-6) << "match " << i << "\n" << J << "\n" << numeric;
    if (!o.stereo) {
      EXPECT_EQ(r(2), 0.0);
    }
  }
  // Behind a pinhole camera: no residual.
  PoseObservation behind;
  behind.P_w = T.inverse() * Eigen::Vector3d(0.1, 0.1, -1.0);
  Eigen::Vector3d r;
  EXPECT_FALSE(spatialResidual(pinhole, 50.0, behind, T, &r));
}

TEST(SpatialPose, RecoversThePoseThroughOutliers) {
  for (const bool huber : {true, false}) {
    Scene s(300, 0.2, 7);
    // A prediction 15 cm and 5 degrees off.
    Eigen::Isometry3d T = pose(Eigen::Vector3d(0.05, -0.06, 0.04), Eigen::Vector3d(0.1, -0.08, 0.06)) * s.T_c_w;
    SpatialPoseOptions opt;
    opt.huber = huber;
    const SpatialPoseResult r = optimiseSpatialPose(s.camera, s.bf, s.obs, opt, &T);
    EXPECT_LT((T.translation() - s.T_c_w.translation()).norm(), 0.01) << "huber " << huber;
    EXPECT_LT(rotationError(T, s.T_c_w), 2e-3) << "huber " << huber;
    test::expectGrossOutliersOut(s.obs, s.is_outlier, r);
  }
}

// The IRLS fixed point is a stationary point of F(T) = sum of rho(s_k(T)) (one round: no match leaves).
TEST(SpatialPose, EstimateIsAStationaryPointOfTheRobustCost) {
  Scene s(120, 0.1, 11);
  for (std::size_t k = 0; k < s.obs.size(); ++k) s.obs[k].alpha = k % 2 ? 1.0 : -0.5;
  SpatialPoseOptions opt;
  opt.rounds = 1;
  opt.iterations = 100;
  Eigen::Isometry3d T = s.T_c_w;
  optimiseSpatialPose(s.camera, s.bf, s.obs, opt, &T);
  auto cost = [&](const Eigen::VectorXd& d) {
    double F = 0;
    for (const PoseObservation& o : s.obs) {
      Eigen::Vector3d r;
      double rho[3];
      EXPECT_TRUE(spatialResidual(s.camera, s.bf, o, steppedBy(T, d), &r));
      BarronKernel(o.alpha, std::sqrt(chi2Gate(o.stereo))).evaluate(r.squaredNorm(), rho);
      F += rho[0];
    }
    return Eigen::VectorXd::Constant(1, F);
  };
  const Eigen::MatrixXd grad = test::numericJacobian(cost, Eigen::VectorXd::Zero(6), 1e-7);
  Eigen::VectorXd away(6);
  away << 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3;  // 1 mrad, 1 mm
  const Eigen::MatrixXd grad_off = test::numericJacobian(cost, away, 1e-7);
  EXPECT_LT(grad.norm(), 1e-3 * grad_off.norm()) << grad << " vs " << grad_off;
}

TEST(SpatialPose, RejectedAndUnusableMatchesNeverMoveThePose) {
  Scene s(150, 0.0, 5);
  Eigen::Isometry3d start = pose(Eigen::Vector3d(0.02, 0.01, -0.02), Eigen::Vector3d(0.05, 0.0, -0.04)) * s.T_c_w;
  Eigen::Isometry3d alone = start;
  const SpatialPoseResult base = optimiseSpatialPose(s.camera, s.bf, s.obs, {}, &alone);
  // A walker: 100 matches that agree on a pose 30 cm and 6 degrees away, rejected by their labels
  // or not to be used; they are classified (all out of the gate) and change nothing.
  Scene walker(100, 0.0, 6);
  walker.T_c_w = pose(Eigen::Vector3d(0.0, 0.1, 0.0), Eigen::Vector3d(0.3, 0.0, 0.0)) * s.T_c_w;
  Scene moved(100, 0.0, 6);  // the same draws, seen from the walker's pose
  std::vector<PoseObservation> all = s.obs;
  for (std::size_t k = 0; k < walker.obs.size(); ++k) {
    PoseObservation o = walker.obs[k];
    o.P_w = walker.T_c_w.inverse() * (moved.T_c_w * o.P_w);
    if (k % 2) {
      o.alpha = -BarronKernel::kInfinity;
    } else {
      o.usable = false;
    }
    all.push_back(o);
  }
  Eigen::Isometry3d with = start;
  const SpatialPoseResult r = optimiseSpatialPose(s.camera, s.bf, all, {}, &with);
  EXPECT_TRUE(with.isApprox(alone, 1e-12)) << with.matrix() << "\n" << alone.matrix();
  EXPECT_EQ(r.inliers, base.inliers);
  for (std::size_t k = s.obs.size(); k < all.size(); ++k) EXPECT_FALSE(r.inlier[k]) << k;
  // Let in, the walker drags the pose: the test above is one it could fail.
  for (std::size_t k = s.obs.size(); k < all.size(); ++k) {
    all[k].alpha = 1.0;
    all[k].usable = true;
  }
  Eigen::Isometry3d dragged = start;
  optimiseSpatialPose(s.camera, s.bf, all, {}, &dragged);
  EXPECT_GT((dragged.translation() - alone.translation()).norm(), 2e-3);
}

}  // namespace
}  // namespace rvwo
