// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Wheel preintegration (eqs. 11 to 13) and the wheel edge (eq. 14): step and edge Jacobians
// against central differences, propagated covariance against Monte Carlo for straight, arc and
// spin-in-place motion (pose readings and wheel encoders), rate independence, the odometry
// extrinsic, splitting readings at frame times, deltas composed, and bad input.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <functional>
#include <random>

#include "../common/numeric.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/edges/wheel_preintegration.h"

namespace rvwo {
namespace {

using test::drawVector;
using test::numericJacobian;
using test::randomAngle;
using test::randomPose;
using test::relativeError;
constexpr double kPi = 3.14159265358979323846;

TEST(WheelPreintegrator, StepJacobiansAgainstNumeric) {
  std::mt19937_64 rng(30);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    WheelPreintegrator pre;
    const double dphi0 = randomAngle(rng, i);
    pre.integrate(drawVector<2>(u, rng), dphi0, Eigen::Matrix3d::Zero());
    const Eigen::Vector2d dp = 0.1 * drawVector<2>(u, rng);
    const double dphi = 0.1 * u(rng);
    Eigen::Matrix3d A, B;
    WheelPreintegrator step = pre;
    step.integrate(dp, dphi, Eigen::Matrix3d::Zero(), &A, &B);
    // next(state, reading) of eq. 11, as a function of the state and of the reading.
    auto next = [](const Eigen::Vector3d& s, const Eigen::Vector3d& m) -> Eigen::VectorXd {
      Eigen::Vector3d o;
      o.head<2>() = s.head<2>() + rotation2(s.z()) * m.head<2>();
      o.z() = s.z() + m.z();
      return o;
    };
    const Eigen::Vector3d s(pre.dp().x(), pre.dp().y(), pre.dphi()), m(dp.x(), dp.y(), dphi);
    worst = std::max(worst, relativeError(A, numericJacobian([&](const Eigen::VectorXd& x) { return next(x, m); }, s)));
    worst = std::max(worst, relativeError(B, numericJacobian([&](const Eigen::VectorXd& x) { return next(s, x); }, m)));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(WheelCalibration, ExpJacobianAgainstNumeric) {
  std::mt19937_64 rng(32);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    // Turns from tiny (the series branch) to large.
    const double w = i % 3 == 0 ? 1e-6 * u(rng) : 2.0 * u(rng);
    const Eigen::Vector2d v = drawVector<2>(u, rng);
    const Eigen::Vector3d xi(v.x(), 0.2 * v.y(), w);
    auto f = [](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      const SE2 T = SE2::exp(x);
      return Eigen::Vector3d(T.translation().x(), T.translation().y(), x.z());
    };
    worst = std::max(worst, relativeError(se2ExpJacobian(xi), numericJacobian(f, xi)));
  }
  EXPECT_LT(worst, 1e-6);
}

// The delta's calibration Jacobian, propagated reading by reading, against integrating again at
// perturbed calibrations (central differences), for encoders and for odometry poses, with an
// odometry extrinsic and with readings split at the ends.
TEST(WheelCalibration, DeltaJacobianAgainstIntegratingAgain) {
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> u(-1, 1);
  const DiffDriveParams drive;
  double worst = 0;
  for (int trial = 0; trial < 40; ++trial) {
    WheelOdometry enc(WheelNoise{},
                      SE2::fromVector(Eigen::Vector3d(0.1, 0.05, 0.3).cwiseProduct(drawVector<3>(u, rng))));
    WheelOdometry pose(WheelNoise{},
                       SE2::fromVector(Eigen::Vector3d(0.1, 0.05, 0.3).cwiseProduct(drawVector<3>(u, rng))));
    double ql = 0, qr = 0;
    SE2 T;
    for (int k = 0; k <= 50; ++k) {
      const double t = 0.02 * k;
      enc.addWheelAngles(t, ql, qr, drive);
      pose.addPose(t, T);
      ql += 0.3 + 0.2 * u(rng);
      qr += 0.3 + 0.2 * u(rng);
      const Eigen::Vector3d r = drawVector<3>(u, rng);
      T = T * SE2::exp(Eigen::Vector3d(0.03 + 0.01 * r.x(), 0.002 * r.y(), 0.1 * r.z()));
    }
    const double t0 = 0.1 + 0.05 * u(rng), t1 = 0.9 + 0.05 * u(rng);
    const WheelCalibration c = Eigen::Vector3d(0.02, 0.02, 0.05).cwiseProduct(drawVector<3>(u, rng));
    for (const WheelOdometry* odo : {&enc, &pose}) {
      const WheelDelta d = odo->integrate(t0, t1, c);
      auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
        const WheelDelta e = odo->integrate(t0, t1, x);
        return Eigen::Vector3d(e.dp.x(), e.dp.y(), e.dphi);
      };
      worst = std::max(worst, relativeError(d.d_calibration, numericJacobian(f, c)));
      // And the first-order delta at a nearby calibration is within second order of the truth.
      const WheelCalibration c2 = c + WheelCalibration(1e-3, -1e-3, 2e-3);
      EXPECT_LT((d.at(c2) - f(c2)).norm(), 1e-5);
    }
  }
  EXPECT_LT(worst, 1e-6);
}

// A differential drive whose radii and track are off: the correction the header names, applied
// to its nominal odometry, gives the true motion (to first order in the errors).
TEST(WheelCalibration, MismatchedWheelsAreCorrected) {
  const DiffDriveParams nominal;  // r = 0.1, b = 0.5
  const double dl = 0.01, dr = -0.01, db = 0.02;
  const double rl = nominal.radius_left * (1 + dl), rr = nominal.radius_right * (1 + dr), b = nominal.track * (1 + db);
  WheelOdometry odo;
  SE2 truth;
  double ql = 0, qr = 0;
  for (int k = 0; k <= 400; ++k) {  // 8 s along a gentle S
    const double t = 0.02 * k;
    odo.addWheelAngles(t, ql, qr, nominal);
    const double v = 0.4, w = 0.3 * std::sin(0.8 * t);  // true body speeds over the next step
    const double dql = (v - w * b / 2) * 0.02 / rl, dqr = (v + w * b / 2) * 0.02 / rr;
    truth = truth * SE2::exp(Eigen::Vector3d(0.5 * (rl * dql + rr * dqr), 0, (rr * dqr - rl * dql) / b));
    ql += dql;
    qr += dqr;
  }
  const WheelCalibration c((dl + dr) / 2, (dl + dr) / 2 - db, (dr - dl) / nominal.track);
  const WheelDelta raw = odo.integrate(0.0, 8.0), fixed = odo.integrate(0.0, 8.0, c);
  const double err_raw = (raw.pose().translation() - truth.translation()).norm();
  const double err_fixed = (fixed.pose().translation() - truth.translation()).norm();
  EXPECT_GT(err_raw, 0.05);  // 3.2 m driven: the bias is worth centimetres
  // First order: what is left is the errors' own size (2 %) times the bias (measured 3.3 %, 2.6 %).
  EXPECT_LT(err_fixed, 0.05 * err_raw);
  EXPECT_LT(std::fabs(wrapAngle(fixed.dphi - truth.angle())), 0.05 * std::fabs(wrapAngle(raw.dphi - truth.angle())));
}

TEST(WheelEdge, JacobiansAgainstNumeric) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-20, 20);
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d xi = randomPose(u, rng, i), xj = randomPose(u, rng, i + 1);
    const Eigen::Vector2d dp = 0.05 * drawVector<2>(u, rng);
    // Keep phi_j - phi_i - dphi away from the wrap at +-pi, where the residual is discontinuous.
    const double dphi = wrapAngle(xj.z() - xi.z() - 0.5 * randomAngle(rng, 3));
    Eigen::Matrix3d Ji, Jj;
    wheelResidual(xi, xj, dp, dphi, &Ji, &Jj);
    worst = std::max(
        worst,
        relativeError(
            Ji, numericJacobian(
                    [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return wheelResidual(x, xj, dp, dphi); }, xi)));
    worst = std::max(
        worst,
        relativeError(
            Jj, numericJacobian(
                    [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return wheelResidual(xi, x, dp, dphi); }, xj)));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(WheelEdge, CalibrationJacobianIsTheDeltas) {
  WheelOdometry odo;
  for (int k = 0; k <= 10; ++k) odo.addWheelAngles(0.1 * k, 0.5 * k, 0.6 * k, DiffDriveParams());
  const WheelDelta d = odo.integrate(0.0, 1.0);
  const WheelEdge edge(d);
  const Eigen::Vector3d xi(1, 2, 0.3), xj(1.3, 2.1, 0.5), c(0.01, -0.02, 0.05);
  Eigen::Matrix3d Ji, Jj, Jc;
  edge.residual(xi, xj, c, &Ji, &Jj, &Jc);
  auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return edge.residual(xi, xj, x, nullptr, nullptr, nullptr);
  };
  EXPECT_LT(relativeError(Jc, numericJacobian(f, c)), 1e-6);
  EXPECT_LT((edge.residual(xi, xj, Eigen::Vector3d::Zero(), nullptr, nullptr, nullptr) - edge.residual(xi, xj)).norm(),
            1e-15);
}

TEST(WheelEdge, ResidualZeroAtTruthAndWrapped) {
  const SE2 Ti(1, 2, 3.0), Tj(4, -1, -3.0);  // crosses +-pi
  WheelDelta d;
  d.dp = Ti.between(Tj).translation();
  d.dphi = Tj.angle() - Ti.angle() + 2 * kPi;  // unwrapped accumulation: 2 pi - 6
  d.covariance = Eigen::Matrix3d::Identity() * 1e-4;
  const WheelEdge e(d);
  EXPECT_LT(e.residual(Ti.vector(), Tj.vector()).norm(), 1e-12);
  EXPECT_NEAR((e.sqrtInformation().transpose() * e.sqrtInformation() - e.information()).norm(), 0, 1e-6);
  d.covariance(2, 2) = -1;
  EXPECT_THROW(WheelEdge{d}, std::invalid_argument);
}

// ---- motion models ----------------------------------------------------------------------------
struct Motion {
  std::function<double(double)> v, w;  // body speed m/s and turn rate rad/s at time t
};
Motion straight() {
  return {[](double) { return 0.8; }, [](double) { return 0.0; }};
}
Motion arc() {
  return {[](double t) { return 0.5 + 0.2 * std::sin(t); }, [](double t) { return 0.4 * std::cos(0.5 * t); }};
}
Motion spin() {
  return {[](double) { return 0.0; }, [](double) { return 0.9; }};
}

// True pose at t, integrated finely (midpoint twist steps of 1e-4 s) from the identity.
SE2 truePose(const Motion& m, double t) {
  SE2 T;
  const int n = static_cast<int>(std::ceil(t / 1e-4));
  const double h = t / n;
  for (int k = 0; k < n; ++k) {
    const double tm = (k + 0.5) * h;
    T = T * SE2::exp(Eigen::Vector3d(m.v(tm) * h, 0.0, m.w(tm) * h));
  }
  return T;
}

std::vector<double> times(double rate, double t_end) {
  std::vector<double> t;
  for (int k = 0; k * (1.0 / rate) <= t_end + 1e-12; ++k) t.push_back(k / rate);
  return t;
}

// Sample covariance of (dp, dphi) over Monte Carlo runs against the propagated covariance.
void expectCovarianceMatches(const std::vector<Eigen::Vector3d>& samples, const Eigen::Matrix3d& predicted, double tol,
                             const char* what) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : samples) mean += s / samples.size();
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (const auto& s : samples) S += (s - mean) * (s - mean).transpose() / (samples.size() - 1);
  const double rel = (S - predicted).norm() / predicted.norm();
  EXPECT_LT(rel, tol) << what << "\nsample\n" << S << "\npredicted\n" << predicted;
}

class WheelMonteCarlo : public ::testing::TestWithParam<int> {};

TEST_P(WheelMonteCarlo, PoseReadingsCovarianceMatchesSamples) {
  const Motion motions[] = {straight(), arc(), spin()};
  const Motion& m = motions[GetParam()];
  WheelNoise noise;
  noise.floor_p = noise.floor_phi = 1e-3;
  const SE2 T_b_o(0.3, -0.1, 0.4);  // odometry frame offset from the body: exercises the extrinsic
  const auto t = times(50.0, 2.0);
  std::vector<SE2> truth_o;
  for (double tk : t) truth_o.push_back(truePose(m, tk) * T_b_o);
  std::mt19937_64 rng(40 + GetParam());
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> samples;
  WheelDelta last;
  for (int run = 0; run < 5000; ++run) {
    WheelOdometry odo(noise, T_b_o);
    SE2 noisy = truth_o[0];
    odo.addPose(t[0], noisy);
    for (std::size_t k = 1; k < t.size(); ++k) {
      const SE2 inc = truth_o[k - 1].between(truth_o[k]);
      const Eigen::Vector3d xi = inc.log();
      const Eigen::Matrix3d L =
          noise.poseReadingCovariance(xi.head<2>().norm(), xi.z(), t[k] - t[k - 1]).llt().matrixL();
      const Eigen::Vector3d n = L * drawVector<3>(g, rng);
      noisy = noisy * SE2(inc.translation() + n.head<2>(), inc.angle() + n.z());
      odo.addPose(t[k], noisy);
    }
    last = odo.integrate(0.2, 1.8);
    samples.emplace_back(last.dp.x(), last.dp.y(), last.dphi);
  }
  // The mean is the true body motion (first order), in the body frame.
  const SE2 true_delta = truePose(m, 0.2).between(truePose(m, 1.8));
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : samples) mean += s / samples.size();
  EXPECT_NEAR((mean.head<2>() - true_delta.translation()).norm(), 0, 3e-3);
  EXPECT_NEAR(wrapAngle(mean.z() - true_delta.angle()), 0, 3e-3);
  expectCovarianceMatches(samples, last.covariance, 0.10, "pose readings");
}

TEST_P(WheelMonteCarlo, EncoderCovarianceMatchesSamples) {
  const Motion motions[] = {straight(), arc(), spin()};
  const Motion& m = motions[GetParam()];
  DiffDriveParams drive;
  drive.radius_left = 0.10;
  drive.radius_right = 0.102;
  drive.track = 0.45;
  WheelNoise noise;
  noise.sigma_wheel = 0.02;
  noise.sigma_y = 0.0;
  noise.floor_p = noise.floor_phi = 1e-4;
  const auto t = times(100.0, 2.0);
  // True cumulative wheel angles: dq = (v -+ w track / 2) dt / r.
  std::vector<Eigen::Vector2d> q(t.size(), Eigen::Vector2d::Zero());
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double tm = 0.5 * (t[k] + t[k - 1]), dt = t[k] - t[k - 1];
    q[k] = q[k - 1] + Eigen::Vector2d((m.v(tm) - m.w(tm) * drive.track / 2) * dt / drive.radius_left,
                                      (m.v(tm) + m.w(tm) * drive.track / 2) * dt / drive.radius_right);
  }
  std::mt19937_64 rng(50 + GetParam());
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> samples;
  WheelDelta last;
  for (int run = 0; run < 5000; ++run) {
    WheelOdometry odo(noise);
    Eigen::Vector2d qn = q[0];
    odo.addWheelAngles(t[0], qn.x(), qn.y(), drive);
    for (std::size_t k = 1; k < t.size(); ++k) {
      const Eigen::Vector2d dq = q[k] - q[k - 1];
      const Eigen::Vector2d n = drawVector<2>(g, rng);
      qn += dq + noise.sigma_wheel *
                     Eigen::Vector2d(std::sqrt(std::fabs(dq.x())) * n.x(), std::sqrt(std::fabs(dq.y())) * n.y());
      odo.addWheelAngles(t[k], qn.x(), qn.y(), drive);
    }
    last = odo.integrate(0.0, 2.0);
    samples.emplace_back(last.dp.x(), last.dp.y(), last.dphi);
  }
  expectCovarianceMatches(samples, last.covariance, 0.10, "encoders");
}

INSTANTIATE_TEST_SUITE_P(StraightArcSpin, WheelMonteCarlo, ::testing::Values(0, 1, 2));

// One long encoder reading (a 1-radian arc): the per-reading covariance G diag(...) G^T itself,
// including the cross terms that the arc's curvature adds, against samples.
TEST(WheelOdometry, EncoderSingleReadingCovarianceMatchesSamples) {
  DiffDriveParams drive;
  WheelNoise noise;
  noise.sigma_wheel = 0.003;
  noise.sigma_y = 0.0;
  noise.floor_p = noise.floor_phi = 0.0;
  const Eigen::Vector2d dq(20.0, 22.5);  // rad: a 2.1 m arc turning 0.5 rad
  std::mt19937_64 rng(60);
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> samples;
  WheelDelta d;
  for (int run = 0; run < 20000; ++run) {
    WheelOdometry odo(noise);
    odo.addWheelAngles(0.0, 0.0, 0.0, drive);
    const Eigen::Vector2d n = drawVector<2>(g, rng);
    odo.addWheelAngles(1.0, dq.x() + noise.sigma_wheel * std::sqrt(dq.x()) * n.x(),
                       dq.y() + noise.sigma_wheel * std::sqrt(dq.y()) * n.y(), drive);
    d = odo.integrate(0.0, 1.0);
    samples.emplace_back(d.dp.x(), d.dp.y(), d.dphi);
  }
  expectCovarianceMatches(samples, d.covariance, 0.05, "one encoder reading");
}

// The part f of a reading carries the fraction f of its noise (a random walk over the motion).
TEST(WheelOdometry, PartOfAReadingCarriesItsShareOfNoise) {
  WheelNoise noise;
  WheelOdometry odo(noise);
  odo.addPose(0.0, SE2(0, 0, 0));
  odo.addPose(1.0, SE2(1.0, 0, 0));
  const Eigen::Matrix3d whole = odo.integrate(0.0, 1.0).covariance;
  EXPECT_NEAR((whole - noise.poseReadingCovariance(1.0, 0.0, 1.0)).norm(), 0, 1e-15);
  EXPECT_NEAR((odo.integrate(0.2, 0.5).covariance - 0.3 * whole).norm(), 0, 1e-15);
}

TEST(WheelOdometry, RateIndependence) {
  const Motion m = arc();
  WheelNoise noise;
  WheelDelta d[2];
  const double rates[] = {20.0, 200.0};
  for (int i = 0; i < 2; ++i) {
    WheelOdometry odo(noise);
    for (double tk : times(rates[i], 6.0)) odo.addPose(tk, truePose(m, tk));
    d[i] = odo.integrate(0.513, 5.271);  // frame times inside readings at both rates
  }
  EXPECT_NEAR((d[0].dp - d[1].dp).norm(), 0, 1e-3);
  EXPECT_NEAR(d[0].dphi - d[1].dphi, 0, 1e-3);
  EXPECT_LT((d[0].covariance - d[1].covariance).norm() / d[1].covariance.norm(), 0.05);
  EXPECT_NEAR(d[0].distance, d[1].distance, 1e-3);
  const SE2 truth = truePose(m, 0.513).between(truePose(m, 5.271));
  EXPECT_NEAR((d[1].dp - truth.translation()).norm(), 0, 1e-3);
}

TEST(WheelOdometry, SplittingAtFrameTimesComposes) {
  WheelOdometry odo;
  const Motion m = arc();
  for (double tk : times(30.0, 3.0)) odo.addPose(tk, truePose(m, tk));
  const WheelDelta a = odo.integrate(0.31, 1.05), b = odo.integrate(1.05, 2.77), ab = odo.integrate(0.31, 2.77);
  const SE2 composed = a.pose() * b.pose();
  EXPECT_NEAR((composed.translation() - ab.dp).norm(), 0, 1e-12);
  EXPECT_NEAR(composed.angle() - wrapAngle(ab.dphi), 0, 1e-12);
  EXPECT_NEAR(a.distance + b.distance, ab.distance, 1e-12);
  // An empty interval is the identity with zero covariance.
  const WheelDelta z = odo.integrate(1.5, 1.5);
  EXPECT_EQ(z.dp.norm(), 0.0);
  EXPECT_EQ(z.covariance.norm(), 0.0);
  // predict() applies the delta to a world pose.
  const SE2 T_w_b0(5, 5, 1.0);
  const SE2 p = odo.predict(T_w_b0, 0.31, 2.77);
  EXPECT_NEAR((p.translation() - (T_w_b0 * ab.pose()).translation()).norm(), 0, 1e-12);
}

TEST(WheelOdometry, WheelSpeedsAndAnglesAgree) {
  DiffDriveParams drive;
  WheelOdometry by_angle, by_speed;
  const double wl = 3.0, wr = 4.0;  // rad/s, constant: the trapezoid rule is exact
  for (double tk : times(50.0, 2.0)) {
    by_angle.addWheelAngles(tk, wl * tk, wr * tk, drive);
    by_speed.addWheelSpeeds(tk, wl, wr, drive);
  }
  const WheelDelta a = by_angle.integrate(0.1, 1.9), s = by_speed.integrate(0.1, 1.9);
  EXPECT_NEAR((a.dp - s.dp).norm(), 0, 1e-12);
  EXPECT_NEAR(a.dphi - s.dphi, 0, 1e-12);
  // Closed form: a circle of radius R = track/2 (vr + vl)/(vr - vl) at rate w.
  const double vl = wl * drive.radius_left, vr = wr * drive.radius_right, w = (vr - vl) / drive.track;
  const SE2 truth = SE2::exp(Eigen::Vector3d(0.5 * (vl + vr) * 1.8, 0, w * 1.8));
  EXPECT_NEAR((a.dp - truth.translation()).norm(), 0, 1e-12);
}

TEST(WheelOdometry, BadInputGetsClearErrors) {
  WheelOdometry odo;
  EXPECT_THROW(odo.firstTime(), std::out_of_range);
  odo.addPose(1.0, SE2(0, 0, 0));
  EXPECT_THROW(odo.addPose(2.0, SE2(std::nan(""), 0, 0)), std::invalid_argument);
  try {
    odo.addPose(0.5, SE2(1, 0, 0));
    FAIL() << "time going backwards accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("timestamps must increase"), std::string::npos) << e.what();
  }
  EXPECT_THROW(odo.addPose(1.0, SE2(1, 0, 0)), std::invalid_argument);                    // repeated time
  EXPECT_THROW(odo.addWheelAngles(2.0, 0, 0, DiffDriveParams()), std::invalid_argument);  // mixed kinds
  odo.addPose(2.0, SE2(1, 0, 0));
  EXPECT_THROW(odo.integrate(0.5, 1.5), std::out_of_range);
  EXPECT_THROW(odo.integrate(1.5, 2.5), std::out_of_range);
  EXPECT_THROW(odo.integrate(1.8, 1.2), std::out_of_range);
  DiffDriveParams bad;
  bad.track = 0;
  WheelOdometry enc;
  EXPECT_THROW(enc.addWheelAngles(0.0, 0, 0, bad), std::invalid_argument);
  WheelNoise n;
  n.sigma_x = -1;
  EXPECT_THROW(WheelOdometry{n}, std::invalid_argument);
}

// Encoders on a random drive (forward, turns both ways, a spin on the spot) at 50 Hz, with the
// odometry frame off the body's: for compose() below.
WheelOdometry randomEncoderDrive(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  WheelOdometry odo(WheelNoise{}, SE2::fromVector(Eigen::Vector3d(0.1, 0.05, 0.3).cwiseProduct(drawVector<3>(u, rng))));
  const DiffDriveParams drive;
  double ql = 0, qr = 0;
  for (int k = 0; k <= 200; ++k) {
    odo.addWheelAngles(0.02 * k, ql, qr, drive);
    const bool spin = k >= 120 && k < 150;
    const double forward = spin ? 0.0 : 0.3 + 0.2 * u(rng), turn = spin ? 0.4 : 0.15 * u(rng);
    ql += forward - turn;
    qr += forward + turn;
  }
  return odo;
}

TEST(WheelDelta, ComposedAtReadingTimesIsIntegratingThrough) {
  std::mt19937_64 rng(34);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst_mean = 0, worst_cov = 0, worst_jac = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const WheelOdometry odo = randomEncoderDrive(rng);
    const WheelCalibration c =
        trial % 2 ? WheelCalibration(Eigen::Vector3d(0.02, 0.02, 0.05).cwiseProduct(drawVector<3>(u, rng)))
                  : WheelCalibration::Zero();
    // Cuts at reading times (0.02 s apart), the whole 4 s in four to six deltas.
    std::vector<double> cuts = {0.0};
    while (cuts.back() < 3.4) cuts.push_back(cuts.back() + 0.02 * (20 + trial % 7 * 5));
    cuts.push_back(4.0);
    WheelDelta chain = odo.integrate(cuts[0], cuts[1], c);
    for (std::size_t k = 2; k < cuts.size(); ++k) chain = compose(chain, odo.integrate(cuts[k - 1], cuts[k], c));
    const WheelDelta whole = odo.integrate(0.0, 4.0, c);
    EXPECT_EQ(chain.t0, 0.0);
    EXPECT_EQ(chain.t1, 4.0);
    worst_mean = std::max(worst_mean, (chain.at(c) - whole.at(c)).norm());
    worst_cov = std::max(worst_cov, relativeError(chain.covariance, whole.covariance));
    worst_jac = std::max(worst_jac, relativeError(chain.d_calibration, whole.d_calibration));
    EXPECT_NEAR(chain.distance, whole.distance, 1e-12);
    EXPECT_NEAR(chain.rotation, whole.rotation, 1e-12);
    EXPECT_EQ(chain.calibration, c);
  }
  EXPECT_LT(worst_mean, 1e-12);
  EXPECT_LT(worst_cov, 1e-12);
  EXPECT_LT(worst_jac, 1e-12);
}

TEST(WheelDelta, ComposedInsideAReadingDiffersOnlyByTheSplitReadingsNoise) {
  std::mt19937_64 rng(35);
  const WheelOdometry odo = randomEncoderDrive(rng);
  const WheelDelta whole = odo.integrate(0.3, 3.7);
  double worst_cov = 0;
  for (const double cut : {0.511, 1.337, 2.401, 2.9999, 3.12}) {  // inside readings (the spin too)
    const WheelDelta chain = compose(odo.integrate(0.3, cut), odo.integrate(cut, 3.7));
    // The mean splits along the reading's constant-twist arc: exact.
    EXPECT_LT((chain.at(WheelCalibration::Zero()) - whole.at(WheelCalibration::Zero())).norm(), 1e-12) << cut;
    EXPECT_LT(relativeError(chain.d_calibration, whole.d_calibration), 1e-3) << cut;
    worst_cov = std::max(worst_cov, relativeError(chain.covariance, whole.covariance));
  }
  EXPECT_GT(worst_cov, 1e-9);  // the split reading's lever arm: not exact...
  EXPECT_LT(worst_cov, 0.02);  // ...but close
}

TEST(WheelDelta, RecalibratedThenComposedIsIntegratingAtTheNewCalibration) {
  std::mt19937_64 rng(36);
  const WheelOdometry odo = randomEncoderDrive(rng);
  const WheelCalibration c1(0.01, -0.02, 0.04);
  EXPECT_THROW(compose(odo.integrate(0.2, 1.6, c1), odo.integrate(1.6, 3.8)), std::invalid_argument);  // calibrations
  EXPECT_THROW(compose(odo.integrate(0.2, 1.6, c1), odo.integrate(1.62, 3.8, c1)), std::invalid_argument);  // a gap
  // Two deltas integrated with calibrations of their own, both moved to c2 and composed: off the
  // integration at c2 by second-order terms only (halving the changes quarters the error), where
  // leaving them at their own would be first-order off.
  double error[2];
  for (int half = 0; half < 2; ++half) {
    const double s = half ? 0.5 : 1.0;
    const WheelCalibration ca = c1 + s * WheelCalibration(2e-3, -1e-3, 3e-3);
    const WheelCalibration cb = c1 + s * WheelCalibration(-2e-3, 3e-3, -4e-3);
    const WheelDelta a = odo.integrate(0.2, 1.6, ca), b = odo.integrate(1.6, 3.8, cb);
    const WheelDelta ab = compose(a.recalibrated(c1), b.recalibrated(c1));
    const WheelDelta truth = odo.integrate(0.2, 3.8, c1);
    EXPECT_EQ(ab.calibration, c1);
    error[half] = (ab.at(c1) - truth.at(c1)).norm();
    EXPECT_GT((compose(a, b.recalibrated(ca)).at(ca) - truth.at(c1)).norm(), 20 * error[half]);
  }
  EXPECT_LT(error[0], 1e-4);
  EXPECT_NEAR(error[0] / error[1], 4.0, 0.5);
}

TEST(WheelOdometry, DropBeforeBoundsMemory) {
  WheelOdometry odo;
  for (double tk : times(100.0, 10.0)) odo.addPose(tk, SE2(tk, 0, 0));
  odo.dropBefore(9.0);
  EXPECT_NEAR(odo.firstTime(), 8.99, 1e-9);
  EXPECT_NEAR(odo.integrate(9.0, 10.0).dp.x(), 1.0, 1e-12);
}

}  // namespace
}  // namespace rvwo
