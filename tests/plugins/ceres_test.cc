// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Ceres adapters: the loss agrees with the core to the last bit; GradientChecker passes on every
// cost; a robust 2-D registration with 40 % gross outliers; the planar bundle adjustment
// recovers the truth (noise-free) or lands within 3 sigma of it (noisy); the odometry's
// calibration priors over a run of BAs.
#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include <ceres/normal_prior.h>
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "../common/numeric.h"
#include "../common/planar_ba.h"
#include "rvwo/ceres/barron_loss.h"
#include "rvwo/ceres/costs.h"
#include "rvwo/ceres/se2_manifold.h"

namespace rvwo {
namespace {

using ceres_adapters::BarronLoss;
using ceres_adapters::SE2Manifold;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(CeresBarronLoss, AgreesWithCoreToTheLastBit) {
  for (double alpha : {-kInf, -7.28, -2.0, -1e-9, 0.0, 0.37, 1.0, 2.0, 3.5, kInf}) {
    const BarronLoss loss(alpha, 1.3);
    const BarronKernel core(alpha, 1.3);
    for (double s : {0.0, 1e-7, 0.3, 2.0, 17.0, 300.0}) {
      double a[3], b[3];
      loss.Evaluate(s, a);
      core.evaluate(s, b);
      for (int i = 0; i < 3; ++i) EXPECT_EQ(a[i], b[i]) << alpha << " " << s;
    }
  }
  BarronLoss loss(1.0);
  loss.setAlpha(-2.0);
  EXPECT_EQ(loss.alpha(), -2.0);
}

TEST(CeresCosts, GradientCheckerPasses) {
  const test::PlanarBA ba(false, 1);
  const SE2Manifold se2;
  std::vector<const ceres::Manifold*> manifolds = {&se2, nullptr};
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  const Se2XyzMonoEdge mono = ba.edge();
  const PinholeCamera& cam = ba.camera;
  const Se2XyzStereoEdge stereo(cam, ba.T_b_c, 0.12 * 450);
  int probes = 0;
  for (const test::Observation& o : ba.observations) {
    if (probes++ >= 200) break;
    Eigen::Vector3d x = ba.poses[o.pose] + 0.01 * test::drawVector<3>(u, rng);
    Eigen::Vector3d P = ba.points[o.point];
    const double* params[] = {x.data(), P.data()};
    ceres::NumericDiffOptions nd;
    ceres::GradientChecker::ProbeResults results;
    const Eigen::Matrix2d S = ceres_adapters::Se2XyzCost<2>::sqrtInformation(
        mono, x, P, 1.5, OutOfPlaneNoise{0.01, Eigen::Matrix2d::Identity() * 1e-4});
    const ceres_adapters::Se2XyzCost<2> cost_m(mono, o.z, S);
    ceres::GradientChecker check_m(&cost_m, &manifolds, nd);
    EXPECT_TRUE(check_m.Probe(params, 1e-7, &results)) << results.error_log;
    Eigen::Vector3d z3;
    stereo.predict(x, P, &z3);
    const ceres_adapters::Se2XyzCost<3> cost_s(stereo, z3 + test::drawVector<3>(u, rng), Eigen::Matrix3d::Identity());
    ceres::GradientChecker check_s(&cost_s, &manifolds, nd);
    EXPECT_TRUE(check_s.Probe(params, 1e-7, &results)) << results.error_log;
  }
  std::vector<const ceres::Manifold*> two_poses = {&se2, &se2};
  for (int k = 0; k + 1 < 6; ++k) {
    const ceres_adapters::WheelCost cost{WheelEdge(ba.wheel[k])};
    Eigen::Vector3d xi = ba.poses[k] + Eigen::Vector3d(0.1, -0.2, 0.3), xj = ba.poses[k + 1];
    const double* params[] = {xi.data(), xj.data()};
    ceres::GradientChecker check(&cost, &two_poses, ceres::NumericDiffOptions());
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(check.Probe(params, 1e-7, &results)) << results.error_log;
    // With the odometry's calibration as a third block (Euclidean).
    const ceres_adapters::WheelCalibratedCost calibrated{WheelEdge(ba.wheel[k])};
    Eigen::Vector3d c(0.01, -0.02, 0.05);
    const double* params3[] = {xi.data(), xj.data(), c.data()};
    std::vector<const ceres::Manifold*> poses_and_c = {&se2, &se2, nullptr};
    ceres::GradientChecker check3(&calibrated, &poses_and_c, ceres::NumericDiffOptions());
    EXPECT_TRUE(check3.Probe(params3, 1e-7, &results)) << results.error_log;
  }
}

TEST(CeresCosts, SE2ManifoldWrapsTheAngle) {
  const SE2Manifold m;
  const double x[3] = {1, 2, 3.1}, d[3] = {0.5, -1, 0.1};
  double y[3], back[3];
  m.Plus(x, d, y);
  EXPECT_NEAR(y[2], 3.2 - 2 * M_PI, 1e-15);
  m.Minus(y, x, back);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], d[i], 1e-15);
}

// 2-D rigid registration: target = R(theta) source + t.
struct Registration {
  Registration(Eigen::Vector2d s, Eigen::Vector2d t) : s_(s), t_(t) {}
  template <typename T>
  bool operator()(const T* x, T* r) const {
    const T c = cos(x[2]), sn = sin(x[2]);
    r[0] = T(t_.x()) - (c * s_.x() - sn * s_.y() + x[0]);
    r[1] = T(t_.y()) - (sn * s_.x() + c * s_.y() + x[1]);
    return true;
  }
  Eigen::Vector2d s_, t_;
};

Eigen::Vector3d fit(const std::vector<Eigen::Vector2d>& src, const std::vector<Eigen::Vector2d>& dst,
                    ceres::LossFunction* loss, const Eigen::Vector3d& start) {
  Eigen::Vector3d x = start;
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (std::size_t i = 0; i < src.size(); ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Registration, 2, 3>(new Registration(src[i], dst[i])),
                             loss, x.data());
  }
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.function_tolerance = o.gradient_tolerance = 1e-16;
  o.parameter_tolerance = 1e-14;
  o.max_num_iterations = 200;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  return x;
}

TEST(CeresBarronLoss, RobustRegistrationWithFortyPercentOutliers) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-3, 3), mag(20, 50), ang(-M_PI, M_PI);
  const Eigen::Vector3d truth(0.7, -0.4, 0.5);
  std::vector<Eigen::Vector2d> src, dst;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d s = test::drawVector<2>(u, rng);
    Eigen::Vector2d d = rotation2(truth.z()) * s + truth.head<2>();
    if (i % 5 < 2) {  // 40 %: gross outliers, 20 to 50 units away in a random direction
      const double a = ang(rng);
      d += mag(rng) * Eigen::Vector2d(std::cos(a), std::sin(a));
    }
    src.push_back(s);
    dst.push_back(d);
  }
  const Eigen::Vector3d start = truth + Eigen::Vector3d(0.3, -0.3, 0.2);  // rough start
  BarronLoss welsch(-kInf), geman(-2.0), ls(2.0);
  const double e_welsch = (fit(src, dst, &welsch, start) - truth).norm();
  const double e_geman = (fit(src, dst, &geman, start) - truth).norm();
  const double e_ls = (fit(src, dst, &ls, start) - truth).norm();
  EXPECT_LT(e_welsch, 1e-6);
  EXPECT_LT(e_geman, 1e-3);
  EXPECT_GT(e_ls, 0.1);
  std::cout << "registration error: alpha=-inf " << e_welsch << ", alpha=-2 " << e_geman << ", least squares " << e_ls
            << "\n";
}

// Per-residual alphas changed between iterations: each residual's alpha follows its current
// error (1 while it fits, -inf once it is far out), as the reliability model does between rounds.
TEST(CeresBarronLoss, AlphaRefreshedBetweenIterations) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(-3, 3);
  const Eigen::Vector3d truth(0.2, 0.1, -0.3);
  std::vector<Eigen::Vector2d> src, dst;
  for (int i = 0; i < 60; ++i) {
    src.push_back(test::drawVector<2>(u, rng));
    dst.push_back(rotation2(truth.z()) * src.back() + truth.head<2>() +
                  (i % 4 == 0 ? Eigen::Vector2d(15, -9) : Eigen::Vector2d::Zero()));
  }
  Eigen::Vector3d x = truth + Eigen::Vector3d(0.1, -0.1, 0.05);
  std::vector<std::unique_ptr<BarronLoss>> losses;
  std::vector<BarronLoss*> raw;
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (std::size_t i = 0; i < src.size(); ++i) {
    losses.push_back(std::make_unique<BarronLoss>(1.0));
    raw.push_back(losses.back().get());
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Registration, 2, 3>(new Registration(src[i], dst[i])),
                             raw.back(), x.data());
  }
  int refreshes = 0;
  ceres_adapters::AlphaRefreshCallback callback(raw, [&](BarronLoss& loss, std::size_t i) {
    const Eigen::Vector2d r = dst[i] - (rotation2(x.z()) * src[i] + x.head<2>());
    loss.setAlpha(r.norm() > 3.0 ? -kInf : 1.0);
    ++refreshes;
  });
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.update_state_every_iteration = true;  // the callback reads x
  o.callbacks.push_back(&callback);
  o.function_tolerance = o.gradient_tolerance = 1e-16;
  o.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  EXPECT_GT(refreshes, 0);
  EXPECT_EQ(refreshes % 60, 0);
  int rejected = 0;
  for (std::size_t i = 0; i < raw.size(); ++i) rejected += std::isinf(raw[i]->alpha());
  EXPECT_EQ(rejected, 15);  // exactly the outliers
  EXPECT_LT((x - truth).norm(), 1e-8);
}

// The planar bundle adjustment, solved with Ceres (SE2Manifold on poses, pose 0 fixed).
struct CeresBA {
  std::vector<Eigen::Vector3d> x, p;
  ceres::Solver::Summary summary;
  CeresBA(const test::PlanarBA& ba, unsigned seed) {
    ba.perturbedStart(seed, &x, &p);
    ceres::Problem problem;
    const Se2XyzMonoEdge edge = ba.edge();
    for (const test::Observation& o : ba.observations) {
      problem.AddResidualBlock(new ceres_adapters::Se2XyzCost<2>(edge, o.z, o.sqrt_information), nullptr,
                               x[o.pose].data(), p[o.point].data());
    }
    for (int k = 0; k + 1 < 6; ++k) {
      problem.AddResidualBlock(new ceres_adapters::WheelCost(WheelEdge(ba.wheel[k])), nullptr, x[k].data(),
                               x[k + 1].data());
    }
    for (auto& xk : x) problem.SetManifold(xk.data(), new SE2Manifold);
    problem.SetParameterBlockConstant(x[0].data());
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::SPARSE_SCHUR;
    o.function_tolerance = o.gradient_tolerance = 1e-16;
    o.parameter_tolerance = 1e-14;
    o.max_num_iterations = 100;
    ceres::Solve(o, &problem, &summary);
  }
};

TEST(CeresPlanarBA, NoiseFreeRecoversTheTruth) {
  const test::PlanarBA ba(false, 7);
  const CeresBA s(ba, 8);
  ASSERT_TRUE(s.summary.IsSolutionUsable()) << s.summary.FullReport();
  double worst = 0;
  for (int k = 0; k < 6; ++k) worst = std::max(worst, (s.x[k] - ba.poses[k]).cwiseAbs().maxCoeff());
  for (std::size_t i = 0; i < ba.points.size(); ++i)
    worst = std::max(worst, (s.p[i] - ba.points[i]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-6) << s.summary.BriefReport();
}

TEST(CeresPlanarBA, NoisyWithinThreeSigma) {
  const test::PlanarBA ba(true, 9);
  const CeresBA s(ba, 10);
  ASSERT_TRUE(s.summary.IsSolutionUsable()) << s.summary.FullReport();
  const Eigen::MatrixXd cov = ba.poseCovariance(s.x, s.p);
  const Eigen::VectorXd err = ba.poseErrors(s.x);
  for (int i = 0; i < 15; ++i) EXPECT_LT(std::fabs(err(i)), 3 * std::sqrt(cov(i, i))) << "pose dof " << i;
  EXPECT_LT(err.dot(cov.ldlt().solve(err)), 37.7);  // chi2(15) at 99.9 %
  // The solver did the work: it converged and reduced the cost by orders of magnitude.
  EXPECT_EQ(s.summary.termination_type, ceres::CONVERGENCE);
  EXPECT_LT(s.summary.final_cost, 1e-2 * s.summary.initial_cost);
}

// One local BA on the odometry's calibration alone: the window's information on it (`data`,
// its sigma `data_sigma`: H) and the priors of addWheelCalibrationPriors (around zero, sigma
// 0.05, 0.05, 0.2; around c, `step`). Moves c.
void calibrationWindow(Eigen::Vector3d* c, const Eigen::Vector3d& data, const Eigen::Vector3d& data_sigma,
                       const Eigen::Vector3d& step, bool first) {
  const Eigen::Vector3d sigma(0.05, 0.05, 0.2), before = *c;
  ceres::Problem problem;
  problem.AddResidualBlock(
      new ceres::NormalPrior(ceres::Matrix(data_sigma.cwiseInverse().asDiagonal()), ceres::Vector(data)), nullptr,
      c->data());
  ceres_adapters::addWheelCalibrationPriors(&problem, c->data(), sigma, step, before, first);
  ceres::Solver::Options so;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  EXPECT_TRUE(summary.IsSolutionUsable());
}

// A run of local BAs, each with weak, unbiased information on the odometry's calibration (a
// window with few turns): the estimate they hand on converges to the truth. With the prior around
// zero counted in every BA (first each time), it settles short of it, at H / (H + 1/sigma^2).
// Returns the estimate after `windows` BAs; `every` adds the zero prior to every one.
Eigen::Vector3d calibrationAfter(int windows, const Eigen::Vector3d& truth, bool every) {
  const Eigen::Vector3d step(0.003, 0.003, 0.005), data_sigma(0.03, 0.03, 0.05);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int w = 0; w < windows; ++w) calibrationWindow(&c, truth, data_sigma, step, every || w == 0);
  return c;
}

TEST(CeresWheelCalibration, TheNominalPriorCountsOnceSoARunOfWindowsReachesTheTruth) {
  const Eigen::Vector3d truth(0.004, -0.0196, -0.049);  // the suite's wheels (turn scale 1/1.02)
  const Eigen::Vector3d once = calibrationAfter(1500, truth, false);
  const Eigen::Vector3d every = calibrationAfter(1500, truth, true);
  EXPECT_LT((once - truth).cwiseAbs().maxCoeff(), 1e-4) << once.transpose();
  // Counted in every window: short by 1/sigma^2 / (H + 1/sigma^2), 26 % of the turn correction.
  const double shrink = (1 / 0.0025) / (1 / 0.0009 + 1 / 0.0025);
  EXPECT_NEAR(every.y(), truth.y() * (1 - shrink), 2e-4) << every.transpose();
  // The prior, once counted, stays a bound: data beyond 3 sigma of nominal meet it.
  const Eigen::Vector3d far = calibrationAfter(1500, Eigen::Vector3d(0.4, -0.3, 1.0), false);
  EXPECT_NEAR(far.x(), 0.15, 1e-9);
  EXPECT_NEAR(far.y(), -0.15, 1e-9);
  EXPECT_NEAR(far.z(), 0.6, 1e-9);
}

// BAs `rate` times a second for `seconds`, each on the same weak data (a sliding window's
// keyframes are mostly the last one's): how far they take c from zero towards the data's value.
double calibrationMovedBy(double rate, double seconds, bool in_time) {
  const Eigen::Vector3d step(0.003, 0.003, 0.005), data_sigma(0.03, 0.03, 0.05), data(0, -0.02, 0);
  const Eigen::Vector3d s = in_time ? ceres_adapters::wheelCalibrationStep(step, 0.5, 1.0 / rate) : step;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  const int n = static_cast<int>(std::lround(rate * seconds));
  for (int w = 0; w < n; ++w) calibrationWindow(&c, data, data_sigma, s, w == 0);
  return -c.y();
}

TEST(CeresWheelCalibration, ItsStepIsAWalkInTimeWhateverTheKeyframeRate) {
  EXPECT_EQ(ceres_adapters::wheelCalibrationStep(Eigen::Vector3d(0.004, 0.002, 0.008), 0.5, 0.125),
            Eigen::Vector3d(0.002, 0.001, 0.004));
  EXPECT_EQ(ceres_adapters::wheelCalibrationStep(Eigen::Vector3d::Ones(), 0.5, 7.0), Eigen::Vector3d::Ones());
  EXPECT_EQ(ceres_adapters::wheelCalibrationStep(Eigen::Vector3d::Ones(), 0.5, 0.0), Eigen::Vector3d::Constant(0.1));
  EXPECT_THROW(ceres_adapters::wheelCalibrationStep(Eigen::Vector3d::Ones(), 0.0, 0.1), std::invalid_argument);
  // Two seconds of BAs on the same weak data: 2 a second (the step's own period), or one every
  // frame (walkers filling the view). In time, the two move c alike (to first order: each BA
  // moves it by H s^2 of the gap, and rate x s^2 is the same); a full step per BA: 11.5x as far.
  const double slow = calibrationMovedBy(2, 2.0, true), fast = calibrationMovedBy(30, 2.0, true);
  EXPECT_GT(slow, 1e-4);
  EXPECT_NEAR(fast / slow, 1.0, 0.05) << slow << " " << fast;
  EXPECT_GT(calibrationMovedBy(30, 2.0, false) / slow, 10.0);
}

// The estimate as both hosts keep it between BAs: copied, its priors added, refined only by a BA
// that had c free. The prior around zero is in the first BA's problem only; the step counts from
// the last BA that refined c, not from one that held it fixed.
TEST(CeresWheelCalibration, TheEstimateCarriesItsPriorAndClockFromBaToBa) {
  const Eigen::Vector3d sigma(0.05, 0.05, 0.2), step(0.004, 0.002, 0.008);
  ceres_adapters::WheelCalibrationEstimate est;
  EXPECT_FALSE(est.learnt);
  EXPECT_EQ(est.step(step, 0.5, 3.0), step);  // no BA yet: the full step
  Eigen::Vector3d c = est.c;
  ceres::Problem first;
  est.addPriors(&first, c.data(), sigma, step, 0.5, 3.0);
  EXPECT_EQ(first.NumResidualBlocks(), 2);  // around zero, around c
  est.refined(Eigen::Vector3d(0.001, -0.002, 0.003), 3.0);
  EXPECT_TRUE(est.learnt);
  EXPECT_EQ(est.t, 3.0);
  // A BA 0.125 s of data later (a quarter period): the prior around c alone, with half the step.
  c = est.c;
  ceres::Problem next;
  est.addPriors(&next, c.data(), sigma, step, 0.5, 3.125);
  ASSERT_EQ(next.NumResidualBlocks(), 1);
  std::vector<ceres::ResidualBlockId> ids;
  next.GetResidualBlocks(&ids);
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d at = est.c;
    at[i] += step[i] / 2;  // one (halved) step off in one coordinate: a whitened residual of 1
    const double* blocks[] = {at.data()};
    Eigen::Vector3d r;
    ASSERT_TRUE(next.GetCostFunctionForResidualBlock(ids[0])->Evaluate(blocks, r.data(), nullptr));
    EXPECT_NEAR(r.norm(), 1.0, 1e-12) << i;
  }
  // A BA that held c fixed learnt nothing and is not refined(): the next, another 0.375 s on,
  // counts from 3.0 s, a whole period: the full step.
  EXPECT_EQ(est.step(step, 0.5, 3.5), step);
}

// What a wheel edge says of the calibration: J_c^T J_c of its whitened residual, J_c by central
// differences on WheelCalibratedCost.
TEST(CeresWheelCalibration, AnEdgesInformationIsItsWhitenedJacobianSquared) {
  const test::PlanarBA ba(false, 5);
  for (int k = 0; k + 1 < 6; ++k) {
    const WheelEdge edge(ba.wheel[k]);
    const ceres_adapters::WheelCalibratedCost cost(edge);
    const Eigen::Vector3d xi = ba.poses[k] + Eigen::Vector3d(0.02, -0.01, 0.03), xj = ba.poses[k + 1];
    const Eigen::Vector3d c(0.01, -0.02, 0.05);
    const auto r = [&](const Eigen::VectorXd& cc) {
      const double* blocks[] = {xi.data(), xj.data(), cc.data()};
      Eigen::Vector3d out;
      cost.Evaluate(blocks, out.data(), nullptr);
      return Eigen::VectorXd(out);
    };
    const Eigen::MatrixXd J = test::numericJacobian(r, c);
    const Eigen::Matrix3d info = ceres_adapters::wheelCalibrationInformation(edge, xi, xj, c);
    EXPECT_LT(test::relativeError(info, J.transpose() * J), 1e-6) << k;
  }
}

// `windows` BAs on the calibration alone, each with fresh data (a window of its own wheel edges:
// truth plus noise of data_sigma), carried by a WheelCalibrationEstimate as the hosts carry it.
struct CalibrationRun {
  ceres_adapters::WheelCalibrationEstimate est;
  std::vector<Eigen::Vector3d> data;
};
CalibrationRun calibrationRun(bool counting, const Eigen::Vector3d& step, int windows, std::uint64_t seed) {
  const Eigen::Vector3d sigma(0.05, 0.05, 0.2), truth(0.004, -0.0196, -0.049), data_sigma(0.003, 0.006, 0.02);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  CalibrationRun run;
  run.est.counting = counting;
  for (int w = 0; w < windows; ++w) {
    const Eigen::Vector3d d = truth + data_sigma.cwiseProduct(test::drawVector<3>(n01, rng));
    run.data.push_back(d);
    const Eigen::Matrix3d data_info = data_sigma.array().square().inverse().matrix().asDiagonal();
    Eigen::Vector3d c = run.est.c;
    ceres::Problem problem;
    problem.AddResidualBlock(
        new ceres::NormalPrior(ceres::Matrix(data_sigma.cwiseInverse().asDiagonal()), ceres::Vector(d)), nullptr,
        c.data());
    const double t = 0.5 * (w + 1);  // a BA a period
    const Eigen::Matrix3d prior = run.est.addPriors(&problem, c.data(), sigma, step, 0.5, t);
    ceres::Solver::Options so;
    so.logging_type = ceres::SILENT;
    so.function_tolerance = so.gradient_tolerance = so.parameter_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    EXPECT_TRUE(summary.IsSolutionUsable());
    run.est.refined(c, t, prior + data_info);
  }
  return run;
}

// Counting, with no drift allowed (a step far below the data), the run of BAs is the batch least
// squares of all windows and the nominal prior, in value and covariance: a recursive estimate.
TEST(CeresWheelCalibration, CountingIsTheBatchLeastSquaresOfAllWindows) {
  const Eigen::Vector3d sigma(0.05, 0.05, 0.2), data_sigma(0.003, 0.006, 0.02);
  const CalibrationRun run = calibrationRun(true, Eigen::Vector3d::Constant(1e-9), 200, 3);
  Eigen::Vector3d info = sigma.array().square().inverse(), weighted = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& d : run.data) {
    info += data_sigma.array().square().inverse().matrix();
    weighted += d.cwiseQuotient(data_sigma.cwiseProduct(data_sigma));
  }
  const Eigen::Vector3d batch = weighted.cwiseQuotient(info);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(run.est.c[i], batch[i], 1e-3 * data_sigma[i] / std::sqrt(200.0)) << i;
    EXPECT_NEAR(run.est.covariance(i, i), 1.0 / info[i], 1e-6 / info[i]) << i;
  }
}

// With a drift of `step` a period, the covariance a BA starts from is the last one's plus step^2:
// a Kalman filter's prediction, then its update by the window's information.
TEST(CeresWheelCalibration, CountingAddsTheDriftBeforeEachWindow) {
  const Eigen::Vector3d step(0.001, 0.002, 0.004), data_sigma(0.003, 0.006, 0.02);
  const CalibrationRun a = calibrationRun(true, step, 5, 4), b = calibrationRun(true, step, 6, 4);
  const Eigen::Matrix3d predicted = a.est.covariance + Eigen::Matrix3d(step.cwiseProduct(step).asDiagonal());
  const Eigen::Matrix3d updated =
      (predicted.inverse() + Eigen::Matrix3d(data_sigma.array().square().inverse().matrix().asDiagonal())).inverse();
  EXPECT_LT((b.est.covariance - updated).cwiseAbs().maxCoeff(), 1e-12 * updated.norm() + 1e-18);
  // Without new data the covariance stops shrinking where drift and data balance (Riccati).
  const CalibrationRun long_run = calibrationRun(true, step, 400, 4);
  const double q = step.x() * step.x(), r = data_sigma.x() * data_sigma.x();
  const double steady = (-q + std::sqrt(q * q + 4 * q * r)) / 2;  // P = ((P + q)^-1 + 1/r)^-1
  EXPECT_NEAR(long_run.est.covariance(0, 0), steady, 1e-9 * r);
}

// Why the hosts count: over the same noisy windows, the estimate a walk hands on is about the last
// window's; counting's converges on the truth as 1/sqrt(windows).
TEST(CeresWheelCalibration, CountingConvergesWhereTheWalkFollowsTheLastWindow) {
  const Eigen::Vector3d truth(0.004, -0.0196, -0.049), data_sigma(0.003, 0.006, 0.02);
  const Eigen::Vector3d walk_step(0.003, 0.003, 0.005), drift(1e-5, 1e-5, 2e-5);
  double counting_err = 0.0, walk_err = 0.0;
  const int runs = 20, windows = 180;  // a 90 s run of the suite, 2 BAs a second
  for (int k = 0; k < runs; ++k) {
    const CalibrationRun c = calibrationRun(true, drift, windows, 100 + k);
    const CalibrationRun w = calibrationRun(false, walk_step, windows, 100 + k);
    counting_err += std::pow((c.est.c.x() - truth.x()) / data_sigma.x(), 2);
    walk_err += std::pow((w.est.c.x() - truth.x()) / data_sigma.x(), 2);
  }
  counting_err = std::sqrt(counting_err / runs);  // in units of one window's sigma
  walk_err = std::sqrt(walk_err / runs);
  EXPECT_LT(counting_err, 3.0 / std::sqrt(windows)) << counting_err;
  EXPECT_GT(walk_err, 0.4) << walk_err;  // a window's own noise, shrunk by the step's prior
}

}  // namespace
}  // namespace rvwo
