// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// solveWindow: recovers the truth from a perturbed start, and a noisy one within its propagated
// covariance; outlier observations are flagged and leave; a spin's wheel edge sits out and stays
// out where vision contradicts it, while the same edge quadratic drags the window; a wheel edge
// that slips against the window leaves the second round; wheels that run long teach the
// calibration (unless the distance scale is held); a rejected point stays where it is; nothing is
// solved without a fixed keyframe when the host asks so; bad indices are refused.
#include "rvwo/tracking/window.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../common/planar_ba.h"
#include "rvwo/edges/se2.h"
#include "rvwo/kernels/barron.h"

namespace rvwo {
namespace {

constexpr double kKeyFrameDt = 0.5;  // s between the scene's poses

// The scene as a window: pose 0 fixed, the others free, mono observations, the scene's wheels.
WindowProblem windowOf(const test::PlanarBA& s, const std::vector<Eigen::Vector3d>& x,
                       const std::vector<Eigen::Vector3d>& P) {
  WindowProblem pb;
  for (std::size_t k = 0; k < x.size(); ++k) pb.keyframes.push_back({x[k], kKeyFrameDt * k, k == 0});
  for (const Eigen::Vector3d& p : P) pb.points.push_back({p, 1.0});
  for (const test::Observation& o : s.observations)
    pb.observations.push_back({o.pose, o.point, Eigen::Vector3d(o.z.x(), o.z.y(), -1), false, s.sigma_px});
  for (int k = 0; k + 1 < static_cast<int>(s.wheel.size()) + 1; ++k) pb.wheels.push_back({k, k + 1, s.wheel[k]});
  return pb;
}

// The same scene seen by a stereo pair (12 cm baseline), exact: metric, as stereo and RGB-D windows
// are (a mono window takes its scale from the wheels).
WindowProblem stereoWindowOf(const test::PlanarBA& s, const Se2XyzStereoEdge& stereo,
                             const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& P) {
  WindowProblem pb = windowOf(s, x, P);
  for (WindowObservation& o : pb.observations) {
    o.stereo = stereo.predict(s.poses[o.keyframe], s.points[o.point], &o.z);
    if (!o.stereo) o.z.z() = -1;
  }
  return pb;
}

Se2XyzStereoEdge stereoOf(const test::PlanarBA& s) { return Se2XyzStereoEdge(s.camera, s.T_b_c, 0.12 * 450); }

WindowOptions plainOptions() {
  WindowOptions o;
  o.calibrate = false;
  o.out_of_plane = OutOfPlaneNoise();
  return o;
}

// A start near the truth, as a host's window starts from tracking's poses: a fifth of the scene's
// perturbation (2 cm and 6 mrad a pose, 2 cm a point).
void nearStart(const test::PlanarBA& s, unsigned seed, std::vector<Eigen::Vector3d>* x,
               std::vector<Eigen::Vector3d>* P) {
  s.perturbedStart(seed, x, P);
  for (std::size_t k = 0; k < x->size(); ++k) (*x)[k] = s.poses[k] + 0.2 * ((*x)[k] - s.poses[k]);
  for (std::size_t i = 0; i < P->size(); ++i) (*P)[i] = s.points[i] + 0.2 * ((*P)[i] - s.points[i]);
}

double maxPoseError(const test::PlanarBA& s, const std::vector<Eigen::Vector3d>& x) {
  double e = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    e = std::max(e, (x[k].head<2>() - s.poses[k].head<2>()).norm());
    e = std::max(e, std::fabs(wrapAngle(x[k].z() - s.poses[k].z())));
  }
  return e;
}

TEST(Window, RecoversTheTruthFromAPerturbedStart) {
  const test::PlanarBA s(false, 1);
  std::vector<Eigen::Vector3d> x, P;
  s.perturbedStart(2, &x, &P);
  const WindowProblem pb = windowOf(s, x, P);
  const WindowSolution sol = solveWindow(s.edge(), nullptr, pb, plainOptions());
  ASSERT_TRUE(sol.ran);
  ASSERT_TRUE(sol.usable);
  EXPECT_LT(maxPoseError(s, sol.x_w_b), 1e-6);
  EXPECT_EQ(sol.x_w_b[0], x[0]);  // fixed
  EXPECT_FALSE(sol.placed[0]);
  for (std::size_t k = 1; k < x.size(); ++k) EXPECT_TRUE(sol.placed[k]);
  for (std::size_t i = 0; i < P.size(); ++i) EXPECT_LT((sol.P_w[i] - s.points[i]).norm(), 1e-5) << i;
  EXPECT_EQ(std::count(sol.outlier.begin(), sol.outlier.end(), 1), 0);
  EXPECT_EQ(sol.wheel_edges, 5);
}

// Huber is quadratic within the gate, where nearly all of 1 px noise lies: the estimate's error
// against the dense Gauss-Newton covariance is a chi2 of 15 degrees of freedom.
TEST(Window, NoisyEstimateWithinItsCovariance) {
  const test::PlanarBA s(true, 3);
  std::vector<Eigen::Vector3d> x, P;
  s.perturbedStart(4, &x, &P);
  x[0] = s.poses[0];
  WindowOptions o = plainOptions();
  o.huber = true;
  o.outliers_leave = false;
  o.second_round_iterations = 30;
  const WindowSolution sol = solveWindow(s.edge(), nullptr, windowOf(s, x, P), o);
  const Eigen::VectorXd e = s.poseErrors(sol.x_w_b);
  const Eigen::MatrixXd C = s.poseCovariance(sol.x_w_b, sol.P_w);
  const double chi2 = e.dot(C.ldlt().solve(e));
  EXPECT_LT(chi2, 37.70);  // 99.9 % of chi2(15)
  EXPECT_GT(chi2, 1.0);    // and not the truth handed back
}

// One observation of every tenth point seen five times or more moved 50 px: the others hold the
// point (with fewer views, mono depth lets a robust kernel follow the bad one).
TEST(Window, OutlierObservationsAreFlaggedAndLeave) {
  test::PlanarBA s(false, 5);
  std::vector<int> views(s.points.size(), 0);
  for (const test::Observation& o : s.observations) ++views[o.point];
  std::vector<char> bad(s.observations.size(), 0), corrupted(s.points.size(), 0);
  for (std::size_t k = 0; k < s.observations.size(); ++k) {
    const int p = s.observations[k].point;
    if (p % 10 != 0 || views[p] < 5 || corrupted[p]) continue;
    s.observations[k].z += Eigen::Vector2d(40, -30);
    bad[k] = corrupted[p] = 1;
  }
  ASSERT_GT(std::count(bad.begin(), bad.end(), 1), 10);
  std::vector<Eigen::Vector3d> x, P;
  nearStart(s, 6, &x, &P);
  const WindowSolution sol = solveWindow(s.edge(), nullptr, windowOf(s, x, P), plainOptions());
  for (std::size_t k = 0; k < bad.size(); ++k) EXPECT_EQ(sol.outlier[k], bad[k]) << k;
  EXPECT_LT(maxPoseError(s, sol.x_w_b), 1e-6);  // they left: the rest is exact
}

// The wheels between poses 3 and 4 claim 0.3 m more than the robot went (spinning in place).
TEST(Window, SpinEdgeSitsOutAndStaysOutWhereVisionContradictsIt) {
  test::PlanarBA s(false, 7);
  s.wheel[3].dp += 0.3 * s.wheel[3].dp.normalized();
  s.wheel[3].covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  std::vector<Eigen::Vector3d> x, P;
  nearStart(s, 8, &x, &P);
  WindowProblem pb = windowOf(s, x, P);
  WindowOptions o = plainOptions();
  o.drop_slipping_wheel_edges = false;
  pb.wheels[3].spin = true;
  const WindowSolution spin = solveWindow(s.edge(), nullptr, pb, o);
  EXPECT_LT(maxPoseError(s, spin.x_w_b), 1e-5);
  EXPECT_EQ(spin.wheel_edges, 4);  // it did not come back
  pb.wheels[3].spin = false;       // the same edge, quadratic
  const WindowSolution quadratic = solveWindow(s.edge(), nullptr, pb, o);
  EXPECT_GT(maxPoseError(s, quadratic.x_w_b), 0.01);
  EXPECT_EQ(quadratic.wheel_edges, 5);
}

TEST(Window, SpinEdgeComesBackWhereTheWindowAgrees) {
  const test::PlanarBA s(false, 9);
  std::vector<Eigen::Vector3d> x, P;
  nearStart(s, 10, &x, &P);
  WindowProblem pb = windowOf(s, x, P);
  pb.wheels[2].spin = true;
  const WindowSolution sol = solveWindow(s.edge(), nullptr, pb, plainOptions());
  EXPECT_EQ(sol.wheel_edges, 5);
  EXPECT_LT(maxPoseError(s, sol.x_w_b), 1e-6);
}

// Stereo: a mono window would take the slipping wheels' scale.
TEST(Window, WheelEdgeThatSlipsAgainstTheWindowLeaves) {
  test::PlanarBA s(false, 11);
  s.wheel[3].dp += 0.3 * s.wheel[3].dp.normalized();  // a slip tracking missed
  s.wheel[3].covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  std::vector<Eigen::Vector3d> x, P;
  nearStart(s, 12, &x, &P);
  const Se2XyzStereoEdge stereo = stereoOf(s);
  WindowOptions o = plainOptions();
  const WindowSolution dropped = solveWindow(s.edge(), &stereo, stereoWindowOf(s, stereo, x, P), o);
  EXPECT_EQ(dropped.wheel_edges_dropped, 1);
  EXPECT_EQ(dropped.wheel_edges, 4);
  EXPECT_LT(maxPoseError(s, dropped.x_w_b), 1e-5);
  o.drop_slipping_wheel_edges = false;
  const WindowSolution kept = solveWindow(s.edge(), &stereo, stereoWindowOf(s, stereo, x, P), o);
  EXPECT_EQ(kept.wheel_edges_dropped, 0);
  EXPECT_GT(maxPoseError(s, kept.x_w_b), 1e-3);
}

// Odometry poses along the true path (constant twist between the scene's poses, 10 readings
// each), every position scaled by `scale`: wheels whose radii are that much too large.
std::vector<WheelDelta> wheelsRunningLong(const test::PlanarBA& s, double scale) {
  WheelOdometry odo;
  SE2 T = SE2::fromVector(s.poses[0]);
  odo.addPose(0.0, SE2(scale * T.translation(), T.angle()));
  for (std::size_t k = 0; k + 1 < s.poses.size(); ++k) {
    const SE2 T_k = SE2::fromVector(s.poses[k]);
    const Eigen::Vector3d xi = T_k.between(SE2::fromVector(s.poses[k + 1])).log();
    for (int i = 1; i <= 10; ++i) {
      T = T_k * SE2::exp(0.1 * i * xi);
      odo.addPose(kKeyFrameDt * (k + 0.1 * i), SE2(scale * T.translation(), T.angle()));
    }
  }
  std::vector<WheelDelta> out;
  for (std::size_t k = 0; k + 1 < s.poses.size(); ++k)
    out.push_back(odo.integrate(kKeyFrameDt * k, kKeyFrameDt * (k + 1)));
  return out;
}

TEST(Window, WheelsThatRunLongTeachTheDistanceScale) {
  test::PlanarBA s(false, 13);
  s.wheel = wheelsRunningLong(s, 1.02);
  std::vector<Eigen::Vector3d> x, P;
  nearStart(s, 14, &x, &P);
  WindowOptions o = plainOptions();
  o.calibrate = true;
  o.calibration_step = Eigen::Vector3d::Constant(0.05);  // one BA may learn it all
  const Se2XyzStereoEdge stereo = stereoOf(s);
  const WindowSolution sol = solveWindow(s.edge(), &stereo, stereoWindowOf(s, stereo, x, P), o);
  ASSERT_TRUE(sol.calibrated);
  // Truth: -0.0196 (1 / 1.02 - 1); the prior around zero (sigma 0.05) takes a little back.
  EXPECT_LT(sol.calibration.x(), -0.012);
  EXPECT_GT(sol.calibration.x(), -0.025);
  // The window follows vision, less dragged by the wheels than with the calibration held at zero.
  EXPECT_LT(maxPoseError(s, sol.x_w_b), 5e-3);
  WindowOptions nominal = o;
  nominal.calibrate = false;
  const WindowSolution uncalibrated = solveWindow(s.edge(), &stereo, stereoWindowOf(s, stereo, x, P), nominal);
  EXPECT_GT(maxPoseError(s, uncalibrated.x_w_b), 1.5 * maxPoseError(s, sol.x_w_b));
  o.hold_distance_scale = true;  // mono: the wheels are its metric
  const WindowSolution held = solveWindow(s.edge(), &stereo, stereoWindowOf(s, stereo, x, P), o);
  EXPECT_EQ(held.calibration.x(), 0.0);
}

TEST(Window, RejectedPointStaysWhereItIs) {
  const test::PlanarBA s(false, 15);
  std::vector<Eigen::Vector3d> x, P;
  s.perturbedStart(16, &x, &P);
  WindowProblem pb = windowOf(s, x, P);
  pb.points[0].alpha = -BarronKernel::kInfinity;
  const WindowSolution sol = solveWindow(s.edge(), nullptr, pb, plainOptions());
  EXPECT_FALSE(sol.solved[0]);
  EXPECT_EQ(sol.P_w[0], P[0]);
  EXPECT_TRUE(sol.solved[1]);
}

TEST(Window, NothingSolvedWithoutAFixedKeyFrameWhenTheHostAsks) {
  const test::PlanarBA s(false, 17);
  std::vector<Eigen::Vector3d> x, P;
  s.perturbedStart(18, &x, &P);
  WindowProblem pb = windowOf(s, x, P);
  pb.keyframes[0].fixed = false;
  WindowOptions o = plainOptions();
  o.needs_a_fixed_keyframe = true;
  o.calibrate = true;  // with calibrated wheel edges: nothing solved, nothing learnt
  const WindowSolution none = solveWindow(s.edge(), nullptr, pb, o);
  EXPECT_FALSE(none.ran);
  EXPECT_FALSE(none.calibrated);
  EXPECT_EQ(none.x_w_b, x);
  o.needs_a_fixed_keyframe = false;
  EXPECT_TRUE(solveWindow(s.edge(), nullptr, pb, o).ran);
  bool stop = true;  // the host asked the solve to end before it began
  o.stop = &stop;
  const WindowSolution stopped = solveWindow(s.edge(), nullptr, pb, o);
  EXPECT_FALSE(stopped.ran);
  EXPECT_FALSE(stopped.calibrated);
}

TEST(Window, BadIndicesAreRefused) {
  const test::PlanarBA s(false, 19);
  WindowProblem pb = windowOf(s, s.poses, s.points);
  pb.observations[0].keyframe = 99;
  EXPECT_THROW(solveWindow(s.edge(), nullptr, pb, plainOptions()), std::invalid_argument);
  pb = windowOf(s, s.poses, s.points);
  pb.wheels[0].b = 0;
  EXPECT_THROW(solveWindow(s.edge(), nullptr, pb, plainOptions()), std::invalid_argument);
  pb = windowOf(s, s.poses, s.points);
  pb.observations[0].stereo = true;
  EXPECT_THROW(solveWindow(s.edge(), nullptr, pb, plainOptions()), std::invalid_argument);
}

}  // namespace
}  // namespace rvwo
