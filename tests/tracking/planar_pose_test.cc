// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// optimisePlanarPose: recovers a known pose from noisy matches with gross outliers, at any angle
// (near +-pi too); the estimate is a stationary point of the robust cost it claims to minimise;
// the wheel prior alone gives its own mean; rejected and unusable matches never move the pose;
// solved from the wheels' prediction, walkers stay out and what fits the new pose comes back.
#include "rvwo/tracking/planar_pose.h"

#include <gtest/gtest.h>

#include <random>

#include "../common/numeric.h"
#include "../common/planar_ba.h"
#include "gate_checks.h"
#include "rvwo/edges/se2.h"
#include "rvwo/kernels/barron.h"

namespace rvwo {
namespace {

struct Scene {
  PinholeCamera camera{400, 400, 319.5, 239.5};
  Eigen::Isometry3d T_b_c = test::forwardCamera();
  double bf = 0.12 * 400;
  Se2XyzMonoEdge mono{camera, T_b_c};
  Se2XyzStereoEdge stereo{camera, T_b_c, bf};
  std::vector<PoseObservation> obs;
  std::vector<char> is_outlier;

  // n matches seen from x_true: every third mono, the rest stereo; pixel noise sigma 1 px at
  // level 0; a fraction `outliers` moved 20 to 60 px off.
  Scene(const Eigen::Vector3d& x_true, int n, double outliers, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), depth(1.5, 12.0), off(20, 60), coin(0, 1);
    std::normal_distribution<double> g(0, 1);
    const Eigen::Isometry3d T_w_c = SE2::fromVector(x_true).isometry3() * T_b_c;
    while (static_cast<int>(obs.size()) < n) {
      const double z = depth(rng);
      const Eigen::Vector2d uv = test::drawVector<2>(u, rng);
      const Eigen::Vector3d P_c(uv.x() * 0.7 * z, uv.y() * 0.5 * z, z);
      PoseObservation o;
      o.P_w = T_w_c * P_c;
      o.stereo = obs.size() % 3 != 0;
      o.sigma_px = pyramidSigma(static_cast<int>(obs.size() % 4));
      Eigen::Vector3d h;
      if (!stereo.predict(x_true, o.P_w, &h)) continue;
      o.z = h + o.sigma_px * test::drawVector<3>(g, rng);
      const bool bad = coin(rng) < outliers;
      if (bad) {
        const Eigen::Vector2d way = test::drawVector<2>(u, rng).normalized();
        o.z.head<2>() += off(rng) * way;
      }
      if (bad) o.z.z() = o.z.x() - (h.x() - h.z());  // a consistent disparity, a wrong place
      obs.push_back(o);
      is_outlier.push_back(bad);
    }
  }
};

double angleError(double a, double b) { return std::fabs(wrapAngle(a - b)); }

TEST(PlanarPose, RecoversThePoseThroughOutliersAtAnyAngle) {
  for (const double theta : {0.3, M_PI - 0.01, -M_PI + 0.005, 1e-8}) {
    for (const bool huber : {true, false}) {
      const Eigen::Vector3d x_true(2.0, -1.0, theta);
      Scene s(x_true, 300, 0.2, 7);
      // A prediction 10 cm and 3 degrees off, across +-pi when theta is near it.
      Eigen::Vector3d x = x_true + Eigen::Vector3d(0.08, -0.06, 0.05);
      x.z() = wrapAngle(x.z());
      PlanarPoseOptions opt;
      opt.huber = huber;
      const PlanarPoseResult r = optimisePlanarPose(s.mono, &s.stereo, s.obs, WheelPrior{}, opt, &x);
      EXPECT_LT((x.head<2>() - x_true.head<2>()).norm(), 0.01) << "theta " << theta << " huber " << huber;
      EXPECT_LT(angleError(x.z(), x_true.z()), 2e-3) << "theta " << theta << " huber " << huber;
      EXPECT_TRUE(std::fabs(x.z()) <= M_PI);
      test::expectGrossOutliersOut(s.obs, s.is_outlier, r);
    }
  }
}

// The IRLS fixed point is a stationary point of F(x) = sum of rho(s_k(x)) plus the prior's squared
// whitened residual (one round: no match leaves; no out-of-plane noise: constant whitening).
TEST(PlanarPose, EstimateIsAStationaryPointOfTheRobustCostWithThePrior) {
  const Eigen::Vector3d x_true(-0.5, 3.0, -2.0);
  Scene s(x_true, 120, 0.1, 11);
  for (std::size_t k = 0; k < s.obs.size(); ++k) s.obs[k].alpha = k % 2 ? 1.0 : -0.5;
  WheelDelta d;
  d.dp << 0.11, 0.01;
  d.dphi = 0.02;
  d.covariance = Eigen::Vector3d(1e-4, 4e-4, 1e-4).asDiagonal();
  const WheelEdge edge(d);
  const Eigen::Vector3d x_prev = (SE2::fromVector(x_true) * SE2(0.1, 0.0, 0.0).inverse()).vector();
  PlanarPoseOptions opt;
  opt.rounds = 1;
  opt.iterations = 100;
  Eigen::Vector3d x = (SE2::fromVector(x_prev) * d.pose()).vector();
  optimisePlanarPose(s.mono, &s.stereo, s.obs, WheelPrior{&edge, x_prev}, opt, &x);
  auto cost = [&](const Eigen::VectorXd& y) {
    double F = (edge.sqrtInformation() * edge.residual(x_prev, y)).squaredNorm();
    for (std::size_t k = 0; k < s.obs.size(); ++k) {
      double chi2 = 0, rho[3];
      EXPECT_TRUE(whitenedChi2(s.mono, &s.stereo, s.obs[k], y, opt.out_of_plane, &chi2));
      BarronKernel(s.obs[k].alpha, std::sqrt(chi2Gate(s.obs[k].stereo))).evaluate(chi2, rho);
      F += rho[0];
    }
    return Eigen::VectorXd::Constant(1, F);
  };
  const Eigen::MatrixXd grad = test::numericJacobian(cost, x, 1e-7);
  // Against the scale of the gradient one step away (1 mm, 1 mrad).
  const Eigen::MatrixXd grad_off = test::numericJacobian(cost, x + Eigen::Vector3d(1e-3, 1e-3, 1e-3), 1e-7);
  EXPECT_LT(grad.norm(), 1e-3 * grad_off.norm()) << grad << " vs " << grad_off;
  // The wheels pulled it: vision alone lands elsewhere.
  Eigen::Vector3d x_vision = (SE2::fromVector(x_prev) * d.pose()).vector();
  optimisePlanarPose(s.mono, &s.stereo, s.obs, WheelPrior{}, opt, &x_vision);
  EXPECT_GT((x_vision - x).norm(), 1e-6);
}

TEST(PlanarPose, WheelPriorAloneGivesItsMean) {
  WheelDelta d;
  d.dp << 0.2, -0.03;
  d.dphi = -0.1;
  d.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  const WheelEdge edge(d);
  const Scene s(Eigen::Vector3d::Zero(), 0, 0.0, 1);
  const Eigen::Vector3d x_prev(1.0, 2.0, M_PI - 0.05);
  Eigen::Vector3d x = x_prev;
  const PlanarPoseResult r = optimisePlanarPose(s.mono, &s.stereo, {}, WheelPrior{&edge, x_prev}, {}, &x);
  const Eigen::Vector3d expected = (SE2::fromVector(x_prev) * d.pose()).vector();
  EXPECT_LT((x.head<2>() - expected.head<2>()).norm(), 1e-9);
  EXPECT_LT(angleError(x.z(), expected.z()), 1e-9);
  EXPECT_EQ(r.inliers, 0);
}

TEST(PlanarPose, RejectedAndUnusableMatchesNeverMoveThePose) {
  const Eigen::Vector3d x_true(0.0, 0.0, 0.4);
  Scene s(x_true, 200, 0.0, 3);
  // Half the matches made to agree on a pose 30 cm away: rejected by alpha or unusable, they
  // must leave the estimate where the other half puts it.
  const Eigen::Vector3d x_other(0.3, 0.0, 0.4);
  Scene liars(x_other, 200, 0.0, 4);
  std::vector<PoseObservation> obs = s.obs;
  for (std::size_t k = 0; k < liars.obs.size(); ++k) {
    PoseObservation o = liars.obs[k];
    // Same pixels as seen from x_other, landmarks placed as if from x_true.
    const Eigen::Isometry3d T = SE2::fromVector(x_true).isometry3() * SE2::fromVector(x_other).isometry3().inverse();
    o.P_w = T * o.P_w;
    if (k % 2) {
      o.alpha = -BarronKernel::kInfinity;
    } else {
      o.usable = false;
    }
    obs.push_back(o);
  }
  for (const bool huber : {false, true}) {
    Eigen::Vector3d x = x_true + Eigen::Vector3d(0.02, 0.02, 0.01);
    PlanarPoseOptions opt;
    opt.huber = huber;
    const PlanarPoseResult r = optimisePlanarPose(s.mono, &s.stereo, obs, WheelPrior{}, opt, &x);
    // Huber ignores alpha (ORB-SLAM's kernel knows nothing of reliability): the alpha-rejected
    // liars count there, and pull; usable = false holds for both.
    if (!huber) {
      EXPECT_LT((x - x_true).norm(), 0.005);
      for (std::size_t k = s.obs.size(); k < obs.size(); ++k) EXPECT_FALSE(r.inlier[k]);
    }
    for (std::size_t k = s.obs.size(); k < obs.size(); k += 2) {
      EXPECT_FALSE(r.inlier[k]);
      EXPECT_GT(r.error[k], 0.0);  // still measured
    }
  }
}

// The wheel gate's solve (solveFromTheWheels): the first round on the matches the wheels'
// prediction explains, the later ones on any the new pose explains. Walkers that agree among
// themselves on a pose 1 cm and 10 mrad off outnumber the static landmarks 3 to 2: solved on all,
// the pose goes their way; from the wheels' prediction (5 cm short along the heading) it stays
// with the static landmarks, the walkers stay out, and the near static landmarks that prediction
// put beyond their gate come back once the far ones have corrected it.
TEST(PlanarPose, SolvedFromTheWheelsTheWalkersStayOutAndWhatFitsComesBack) {
  const Eigen::Vector3d x_true(1.0, -2.0, 0.7);
  Scene s(x_true, 100, 0.0, 5);
  const Eigen::Vector3d x_walkers = x_true + Eigen::Vector3d(0.0, 0.01, 0.01);
  Scene walkers(x_walkers, 150, 0.0, 6);
  std::vector<PoseObservation> obs = s.obs;  // then the walkers: seen as if from x_walkers
  obs.insert(obs.end(), walkers.obs.begin(), walkers.obs.end());
  const PlanarPoseOptions opt;
  Eigen::Vector3d x_all = x_true;
  optimisePlanarPose(s.mono, &s.stereo, obs, WheelPrior{}, opt, &x_all);
  EXPECT_GT(angleError(x_all.z(), x_true.z()), 5e-3);  // dragged at least half way
  const Eigen::Vector3d x_pred = (SE2::fromVector(x_true) * SE2(-0.05, 0.0, 0.0)).vector();
  std::vector<char> out_at_pred(obs.size(), 0);
  for (std::size_t k = 0; k < s.obs.size(); ++k) {
    double e2 = 1e9;
    out_at_pred[k] =
        !whitenedChi2(s.mono, &s.stereo, obs[k], x_pred, opt.out_of_plane, &e2) || e2 > chi2Gate(obs[k].stereo);
  }
  const int static_out_at_pred = static_cast<int>(std::count(out_at_pred.begin(), out_at_pred.end(), 1));
  EXPECT_GE(static_out_at_pred, 10);
  EXPECT_LE(static_out_at_pred, 60);
  const std::vector<char> counted(obs.size(), 1);
  Eigen::Vector3d x = Eigen::Vector3d::Constant(9);
  PlanarPoseResult r;
  ASSERT_TRUE(solveFromTheWheels(s.mono, &s.stereo, obs, WheelPrior{}, opt, x_pred, counted, 30, &x, &r));
  EXPECT_LT((x.head<2>() - x_true.head<2>()).norm(), 6e-3);  // 4 mm here: the noise of 100 matches
  EXPECT_LT(angleError(x.z(), x_true.z()), 5e-4);
  int static_in = 0, came_back = 0, walkers_in = 0;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    (k < s.obs.size() ? static_in : walkers_in) += r.inlier[k];
    came_back += out_at_pred[k] && r.inlier[k];
  }
  EXPECT_GT(static_in, 85);
  EXPECT_GT(came_back, 0.8 * static_out_at_pred);
  EXPECT_LT(walkers_in, 15);
  // Too few agree: nothing solved, nothing touched.
  x = Eigen::Vector3d::Constant(9);
  EXPECT_FALSE(solveFromTheWheels(s.mono, &s.stereo, obs, WheelPrior{}, opt, x_pred, counted, 400, &x, &r));
  EXPECT_EQ(x, Eigen::Vector3d::Constant(9));
  // Only counted matches count: of the static ones (100), fewer agree than all of them.
  std::vector<char> static_only(obs.size(), 0);
  std::fill(static_only.begin(), static_only.begin() + static_cast<std::ptrdiff_t>(s.obs.size()), 1);
  EXPECT_FALSE(solveFromTheWheels(s.mono, &s.stereo, obs, WheelPrior{}, opt, x_pred, static_only,
                                  100 - static_out_at_pred + 1, &x, &r));
  EXPECT_TRUE(solveFromTheWheels(s.mono, &s.stereo, obs, WheelPrior{}, opt, x_pred, static_only,
                                 100 - static_out_at_pred, &x, &r));
}

// PlanarPoseResult::information, inverted, is the scatter of vision alone's pose over the pixel
// noise (Monte Carlo, 400 frames of 150 matches with the same landmarks).
TEST(PlanarPose, InformationIsTheInverseOfThePoseScatter) {
  const Eigen::Vector3d x_true(0.5, 1.0, -0.7);
  Scene s(x_true, 150, 0.0, 21);
  std::mt19937_64 rng(22);
  std::normal_distribution<double> g(0, 1);
  PlanarPoseOptions opt;
  opt.huber = true;
  const int trials = 400;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero(), covariance = Eigen::Matrix3d::Zero();
  for (int t = 0; t < trials; ++t) {
    for (PoseObservation& o : s.obs) {
      Eigen::Vector3d h;
      ASSERT_TRUE(s.stereo.predict(x_true, o.P_w, &h));
      o.z = h + o.sigma_px * test::drawVector<3>(g, rng);
    }
    Eigen::Vector3d x = x_true + Eigen::Vector3d(0.02, -0.01, 0.01);
    const PlanarPoseResult r = optimisePlanarPose(s.mono, &s.stereo, s.obs, WheelPrior{}, opt, &x);
    Eigen::Vector3d e = x - x_true;
    e.z() = wrapAngle(e.z());
    scatter += e * e.transpose() / trials;
    covariance += r.information.inverse() / trials;
  }
  // Each variance within 20 % (400 samples: about 7 % standard error); correlations alike.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(scatter(i, i) / covariance(i, i), 1.0, 0.2) << "\n" << scatter << "\n" << covariance;
    for (int j = 0; j < i; ++j) {
      const double rho_s = scatter(i, j) / std::sqrt(scatter(i, i) * scatter(j, j));
      const double rho_c = covariance(i, j) / std::sqrt(covariance(i, i) * covariance(j, j));
      EXPECT_NEAR(rho_s, rho_c, 0.15) << i << j;
    }
  }
}

TEST(PlanarPose, StereoObservationWithoutStereoEdgeThrows) {
  Scene s(Eigen::Vector3d::Zero(), 3, 0.0, 5);
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  EXPECT_THROW(optimisePlanarPose(s.mono, nullptr, s.obs, WheelPrior{}, {}, &x), std::invalid_argument);
}

}  // namespace
}  // namespace rvwo
