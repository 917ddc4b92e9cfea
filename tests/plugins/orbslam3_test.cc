// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// The ORB-SLAM3 plugin's wheel input, without ORB-SLAM3: predictions against poses composed
// directly, the keyframe rule, settings, bad readings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "../common/temp.h"
#include "orbslam3_common.h"
#include "orbslam3_segmenters.h"
#include "rvwo/edges/se2.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/orbslam3/wheel_input.h"
#include "rvwo/semantics/segmenter.h"

namespace {

using rvwo::test::HalfPerson;

using rvwo::orbslam3::WheelInput;
using rvwo::orbslam3::WheelInputParams;
using rvwo::orbslam3::WheelReading;
using rvwo::test::cameraPose;
using rvwo::test::robotOf;
using rvwo::test::tiltedCamera;

// Ground truth: a drive that turns both ways and passes theta = +-pi.
rvwo::SE2 truth(double t) {
  const double theta = 2.6 + 0.9 * std::sin(0.7 * t);
  return rvwo::SE2(1.5 * std::cos(0.3 * t) + 0.2 * t, 1.2 * std::sin(0.3 * t), theta);
}

TEST(WheelInput, InactiveUntilConfiguredAndRefusesReadingsThen) {
  WheelInput w;
  EXPECT_FALSE(w.active());
  EXPECT_FALSE(w.covers(0, 1));
  EXPECT_FALSE(w.keyFrameNeeded());
  EXPECT_NO_THROW(w.add({}));  // upstream's calls without readings
  EXPECT_THROW(w.add({WheelReading::angles(0, 0, 0)}), std::invalid_argument);
  w.frameTracked(0, false, 1000);
  EXPECT_EQ(w.wheelOnlyFrames(), 0u);
}

TEST(WheelInput, PredictsTheCameraPoseTheTruthGives) {
  WheelInputParams p;
  p.T_b_c = tiltedCamera();
  p.T_b_o.translation() << -0.1, 0.05, 0;  // odometry frame behind the base, rotated 20 deg
  p.T_b_o.linear() = Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  WheelInput w;
  w.configure(p);
  ASSERT_TRUE(w.active());
  const rvwo::SE2 T_b_o(p.T_b_o.translation().head<2>(), 0.35);
  // The robot's odometry reports T_odom_o at 100 Hz, its world rotated and shifted from ours.
  const rvwo::SE2 T_odom_w(3.0, -2.0, 1.1);
  std::vector<WheelReading> readings;
  for (int k = 0; k <= 1000; ++k) {
    const double t = 0.01 * k;
    const rvwo::SE2 T_odom_o = T_odom_w * truth(t) * T_b_o;
    readings.push_back(WheelReading::pose(t, T_odom_o.translation().x(), T_odom_o.translation().y(), T_odom_o.angle()));
  }
  w.add(readings);
  EXPECT_FALSE(w.covers(-0.1, 1.0));
  EXPECT_FALSE(w.covers(9.0, 10.1));
  EXPECT_FALSE(w.covers(2.0, 1.0));
  EXPECT_THROW(w.predict(Eigen::Isometry3d::Identity(), 9.0, 10.1), std::out_of_range);
  // Camera frames at 30 Hz (between readings), and a gap of a second.
  const std::pair<double, double> spans[] = {{0.0, 1.0 / 30}, {4.0 / 30, 5.0 / 30}, {3.01, 4.02}, {9.95, 10.0}};
  for (const auto& [ti, tj] : spans) {
    ASSERT_TRUE(w.covers(ti, tj));
    const Eigen::Isometry3d T_ci_w = (truth(ti).isometry3() * p.T_b_c).inverse();
    const Eigen::Isometry3d T_cj_w = (truth(tj).isometry3() * p.T_b_c).inverse();
    const Eigen::Isometry3d predicted = w.predict(T_ci_w, ti, tj);
    // Readings straddling a frame are split along their constant-twist arc: exact up to the
    // arc's difference from the truth's curve over 10 ms.
    EXPECT_LT((predicted.translation() - T_cj_w.translation()).norm(), 2e-4) << ti << " " << tj;
    EXPECT_LT(Eigen::AngleAxisd(predicted.linear().transpose() * T_cj_w.linear()).angle(), 2e-4) << ti << " " << tj;
  }
  // At reading times the pose input is exact.
  const Eigen::Isometry3d T_ci_w = (truth(2.0).isometry3() * p.T_b_c).inverse();
  const Eigen::Isometry3d T_cj_w = (truth(2.5).isometry3() * p.T_b_c).inverse();
  EXPECT_TRUE(w.predict(T_ci_w, 2.0, 2.5).isApprox(T_cj_w, 1e-9));
}

TEST(WheelInput, WheelAnglesDriveTheCameraAlongItsAxis) {
  WheelInputParams p;
  p.T_b_c = tiltedCamera();
  p.radius_left = p.radius_right = 0.08;
  WheelInput w;
  w.configure(p);
  w.add({WheelReading::angles(0.0, 1.0, 2.0), WheelReading::angles(0.5, 1.0 + 5.0, 2.0 + 5.0)});
  // Both wheels turned 5 rad: 0.4 m straight ahead; the camera moves along its own axis, tilted.
  const Eigen::Isometry3d T_cj_w = w.predict(Eigen::Isometry3d::Identity(), 0.0, 0.5);
  const Eigen::Vector3d along = p.T_b_c.linear().transpose() * Eigen::Vector3d(0.4, 0, 0);
  EXPECT_TRUE(T_cj_w.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(T_cj_w.translation().isApprox(-along, 1e-12));
  EXPECT_NEAR(along.z(), 0.4 * std::cos(5 * M_PI / 180), 1e-12);
}

TEST(WheelInput, BadReadingsAreRefused) {
  WheelInput w;
  w.configure(WheelInputParams());
  w.add({WheelReading::speeds(1.0, 0, 0)});
  EXPECT_THROW(w.add({WheelReading::speeds(2.0, NAN, 0)}), std::invalid_argument);
  EXPECT_THROW(w.add({WheelReading::speeds(0.5, 1, 1)}), std::invalid_argument);  // back in time
  EXPECT_THROW(w.add({WheelReading::angles(3.0, 1, 1)}), std::invalid_argument);  // another kind
}

TEST(WheelInput, KeyframesRestartTheMapWhileOnTheWheels) {
  WheelInput w;
  w.configure(WheelInputParams());
  std::vector<int> asked;
  for (int k = 0; k < 20; ++k) {
    const bool visual = k < 3 || k >= 15;
    const int features = k < 6 ? 0 : 800;  // lens covered until frame 6
    w.frameTracked(0.1 * k, visual, features);
    if (w.keyFrameNeeded()) asked.push_back(k);
    // ORB-SLAM3's own wish stands, but for a frame on the wheels too blind for map points.
    EXPECT_EQ(w.keyFrameWanted(true), visual || features >= 500) << k;
    EXPECT_EQ(w.keyFrameWanted(false), w.keyFrameNeeded()) << k;
  }
  // On the wheels from frame 3 to 14: none while blind, then every 5th frame, none once visual.
  EXPECT_EQ(asked, (std::vector<int>{9, 14}));
  EXPECT_EQ(w.wheelOnlyFrames(), 12u);
  ASSERT_EQ(w.wheelOnlyIntervals().size(), 1u);
  EXPECT_DOUBLE_EQ(w.wheelOnlyIntervals()[0].first, 0.3);
  EXPECT_DOUBLE_EQ(w.wheelOnlyIntervals()[0].second, 1.4);
  // A frame that fails alone asks for nothing; a monocular map not in metres (no wheel scale):
  // never, and no triangulation in time.
  w.frameTracked(2.0, false, 800);
  EXPECT_FALSE(w.keyFrameNeeded());
  EXPECT_EQ(w.wheelOnlyIntervals().size(), 2u);
  EXPECT_FALSE(w.triangulatesInTime());  // stereo: its keyframes bring their points
  WheelInputParams mono;
  mono.map_from_depth = false;
  WheelInput m;
  m.configure(mono);
  for (int k = 0; k < 20; ++k) {
    m.frameTracked(0.1 * k, false, 800);
    EXPECT_FALSE(m.keyFrameNeeded());
  }
  EXPECT_FALSE(m.triangulatesInTime());
  WheelInput inactive;  // upstream's behaviour
  EXPECT_TRUE(inactive.keyFrameWanted(true));
  EXPECT_FALSE(inactive.keyFrameWanted(false));
}

TEST(WheelInput, ReadsRvwoKeysFromTheSettings) {
  const auto path = rvwo::test::scratch("orbslam3_settings.yaml");
  auto write = [&](const std::string& body) { std::ofstream(path) << "%YAML:1.0\nCamera1.fx: 400\n" << body; };
  WheelInput w;
  write("");  // upstream's settings: no RVWO keys, upstream behaviour
  w.configure(path.string());
  EXPECT_FALSE(w.active());
  EXPECT_FALSE(w.alignedPyramid());  // upstream's pyramid
  write("Sensor: \"mono\"\nOdometry.Track: 0.4\n");
  try {
    w.configure(path.string());
    FAIL() << "no Camera.T_b_c";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("missing key Camera.T_b_c"), std::string::npos) << e.what();
  }
  write(
      "Sensor: \"mono\"\nOdometry.Track: 0.4\nOdometry.WheelRadiusLeft: 0.05\nOdometry.WheelRadiusRight: 0.05\n"
      "Camera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
      "   data: [0, 0, 1, 0.25, -1, 0, 0, 0, 0, -1, 0, 0.4, 0, 0, 0, 1]\n");
  w.configure(path.string());
  ASSERT_TRUE(w.active());
  // 0.05 m wheels turned 2 rad: 0.1 m; turned apart by 1.6 rad: 0.2 rad about the 0.4 m track.
  w.add({WheelReading::angles(0, 0, 0), WheelReading::angles(1, 2, 2), WheelReading::angles(2, 2 - 0.8, 2 + 0.8)});
  EXPECT_NEAR(w.predict(Eigen::Isometry3d::Identity(), 0, 1).translation().z(), -0.1, 1e-12);
  const Eigen::Isometry3d turn = w.predict(Eigen::Isometry3d::Identity(), 1, 2);
  EXPECT_NEAR(Eigen::AngleAxisd(turn.linear()).angle(), 0.2, 1e-12);
  for (int k = 0; k < 5; ++k) w.frameTracked(k, false, 1000);
  EXPECT_FALSE(w.keyFrameNeeded());  // mono
  write(
      "Odometry.Track: -1\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
      "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
  EXPECT_THROW(w.configure(path.string()), std::invalid_argument);
  // A kernel it does not know, named with its key.
  write(
      "Tracking.Kernel: \"cauchy\"\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
      "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
  try {
    w.configure(path.string());
    FAIL() << "a bad Tracking.Kernel";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("Tracking.Kernel"), std::string::npos) << e.what();
  }
  // A spin's frames: a whole number, at least 1, named with its key.
  for (const char* bad : {"0", "2.5", "-3"}) {
    write(std::string("LocalMapping.SpinMinFrames: ") + bad +
          "\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
          "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
    try {
      w.configure(path.string());
      FAIL() << "LocalMapping.SpinMinFrames " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("LocalMapping.SpinMinFrames"), std::string::npos) << e.what();
    }
  }
  // The essential graph on SE(2) unless LoopClosing.Planar 0; its vision sigmas must be > 0.
  const std::string stereo =
      "Sensor: \"stereo\"\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
      "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n";
  write(stereo);
  w.configure(path.string());
  EXPECT_TRUE(w.optimisesEssentialGraphs());
  EXPECT_TRUE(w.alignedPyramid());  // by default, with the wheels
  write(stereo + "ORBextractor.AlignedPyramid: 0\n");
  w.configure(path.string());
  EXPECT_TRUE(w.active());
  EXPECT_FALSE(w.alignedPyramid());
  write(stereo + "LoopClosing.Planar: 0\n");
  w.configure(path.string());
  EXPECT_TRUE(w.optimisesLocalMaps());
  EXPECT_FALSE(w.optimisesEssentialGraphs());
  write(stereo + "LoopClosing.SigmaYaw: 0\n");
  try {
    w.configure(path.string());
    FAIL() << "LoopClosing.SigmaYaw 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("LoopClosing.SigmaXY and .SigmaYaw"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

// ---- pose optimisation on SE(2) (optimisePose), on a synthetic stereo frame

using rvwo::orbslam3::PoseMatch;
using rvwo::orbslam3::PoseProblem;
using rvwo::orbslam3::PoseSolution;

struct StereoFrame {
  PoseProblem problem;
  std::vector<char> bad;
  // n matches seen from x_true (1 px noise at level 0), a fraction of them 30 px off.
  StereoFrame(const rvwo::SE2& x_true, const Eigen::Isometry3d& T_b_c, int n, double outliers, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), depth(1.5, 10.0), coin(0, 1);
    std::normal_distribution<double> g(0, 1);
    problem.fx = problem.fy = 400;
    problem.cx = 319.5;
    problem.cy = 239.5;
    problem.bf = 0.12 * 400;
    problem.scale_factor = 1.2;
    problem.has_previous = false;
    const Eigen::Isometry3d T_w_c = cameraPose(x_true, T_b_c).inverse();
    for (int k = 0; k < n; ++k) {
      const double z = depth(rng);
      const Eigen::Vector2d uv = rvwo::test::drawVector<2>(u, rng);
      const Eigen::Vector3d P_c(uv.x() * 0.7 * z, uv.y() * 0.5 * z, z);
      PoseMatch m;
      m.P_w = T_w_c * P_c;
      m.level = k % 3;
      const double s = std::pow(1.2, m.level);
      m.u = 400 * P_c.x() / z + 319.5 + s * g(rng);
      m.v = 400 * P_c.y() / z + 239.5 + s * g(rng);
      m.u_right = m.u - problem.bf / z;
      bad.push_back(coin(rng) < outliers);
      if (bad.back()) m.u += 30, m.u_right += 30;
      m.id = static_cast<unsigned long>(k);
      problem.matches.push_back(m);
    }
  }
};

// The odometry reports the truth (or, slipping, what `claimed` says) at 100 Hz over [0, 1].
void addReadings(WheelInput& w, const std::function<rvwo::SE2(double)>& claimed) {
  std::vector<WheelReading> readings;
  for (int k = 0; k <= 100; ++k) {
    const rvwo::SE2 x = claimed(0.01 * k);
    readings.push_back(WheelReading::pose(0.01 * k, x.translation().x(), x.translation().y(), x.angle()));
  }
  w.add(readings);
}
void configureWheels(WheelInput& w, const Eigen::Isometry3d& T_b_c, const std::function<rvwo::SE2(double)>& claimed,
                     bool slip_check = true) {
  WheelInputParams p;
  p.T_b_c = T_b_c;
  p.tracking.slip_check = slip_check;
  w.configure(p);
  addReadings(w, claimed);
}

TEST(WheelInputPose, PlacesTheFrameOnThePlaneThroughOutliers) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  auto drive = [](double t) { return rvwo::SE2(0.5 * t, 0.1 * t * t, M_PI - 0.05 + 0.2 * t); };  // across +-pi
  WheelInput w;
  configureWheels(w, T_b_c, drive);
  ASSERT_TRUE(w.optimisesPoses());
  StereoFrame f(drive(0.5), T_b_c, 200, 0.15, 3);
  f.problem.t = 0.5;
  f.problem.has_previous = true;
  f.problem.t_previous = 0.5 - 1.0 / 30;
  f.problem.T_cp_w = cameraPose(drive(f.problem.t_previous), T_b_c);
  // Predicted 6 cm and 3 degrees off, and out of the plane (as a 6-DoF pose may be).
  Eigen::Isometry3d T_c_w = cameraPose(drive(0.5) * rvwo::SE2(0.05, -0.03, 0.05), T_b_c);
  T_c_w.translation().y() += 0.02;
  f.problem.T_c_w = T_c_w;
  PoseSolution s;
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  double off_plane = 1;
  const rvwo::SE2 x = robotOf(s.T_c_w, T_b_c, &off_plane);
  const rvwo::SE2 e = drive(0.5).inverse() * x;
  EXPECT_LT(e.translation().norm(), 0.004);
  EXPECT_LT(std::fabs(e.angle()), 1e-3);
  EXPECT_LT(off_plane, 1e-9);
  EXPECT_FALSE(s.slip);
  int good = 0, good_in = 0;
  for (std::size_t k = 0; k < f.bad.size(); ++k) {
    if (f.bad[k]) {
      EXPECT_TRUE(s.outlier[k]) << k;
    } else {
      ++good;
      good_in += !s.outlier[k];
    }
  }
  EXPECT_EQ(s.inliers, good_in);
  EXPECT_GT(good_in, 0.85 * good);
  // Fewer than 3 matches: ORB-SLAM3's own optimisation is to run.
  f.problem.matches.resize(2);
  EXPECT_FALSE(w.optimisePose(f.problem, &s));
}

TEST(WheelInputPose, WheelsThatSlipLoseToVision) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  const rvwo::SE2 still(1.0, 2.0, 0.3);
  // The robot stands still while its wheels claim 60 cm/s ahead (spinning on a wet floor).
  WheelInput w;
  configureWheels(w, T_b_c, [&](double t) { return still * rvwo::SE2(0.6 * t, 0, 0); });
  StereoFrame f(still, T_b_c, 200, 0.0, 5);
  f.problem.t = 0.5;
  f.problem.has_previous = true;
  f.problem.t_previous = 0.4;
  f.problem.T_cp_w = cameraPose(still, T_b_c);
  f.problem.T_c_w = cameraPose(still * rvwo::SE2(0.06, 0, 0), T_b_c);  // the wheels' prediction
  PoseSolution s;
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  EXPECT_TRUE(s.slip);
  // Counted once the frame is tracked, however often it was solved (ORB-SLAM3: twice).
  EXPECT_EQ(w.slipFrames(), 0u);
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  EXPECT_TRUE(s.slip);
  w.frameTracked(f.problem.t, true, 200);
  EXPECT_EQ(w.slipFrames(), 1u);
  double off_plane = 1;
  EXPECT_LT((still.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm(), 0.002);
  // Without the slip check the wheel edge stays, and pulls the pose along the wheels' claim.
  WheelInput trusting;
  configureWheels(
      trusting, T_b_c, [&](double t) { return still * rvwo::SE2(0.6 * t, 0, 0); }, false);
  ASSERT_TRUE(trusting.optimisePose(f.problem, &s));
  EXPECT_FALSE(s.slip);
  const rvwo::SE2 pulled = still.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane);
  EXPECT_GT(pulled.translation().x(), 0.004);
  // The same frame with wheels that tell the truth: no slip.
  WheelInput honest;
  configureWheels(honest, T_b_c, [&](double) { return still; });
  ASSERT_TRUE(honest.optimisePose(f.problem, &s));
  EXPECT_FALSE(s.slip);
  EXPECT_LT((still.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm(), 0.002);
}

// A spin: from 0.5 s the robot stands while its wheels claim 0.9 m/s on. Tracking catches it (vision
// alone wins from the third frame on), and the local map's wheel edges across it sit out its first
// half; the keyframes there disagree with them, so they stay out, and the keyframes stay where
// vision puts them (observed without noise here: exactly there). There from the start, even under
// Huber, the edges pulled the keyframes 3, 10 and 40 mm along the claim: on points 3 to 40 m away
// vision weighs little along the optical axis. (The estimator's twin: stereo combined seed 3,
// 16 cm.)
// The robot stands from 0.5 s while its wheels go on at 0.9 m/s; tracking catches the slip, then
// the local map of keyframes at 0.3 to 0.9 s. Returns the free keyframes' largest distance from
// where vision put them (the truth), and the wheel edges of the solution.
double spinKeyframeError(int spin_min_frames, int* wheel_edges) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  const auto truth = [](double t) { return rvwo::SE2(0.3 * std::min(t, 0.5), 0.0, 0.1); };
  WheelInput w;
  WheelInputParams p;
  p.T_b_c = T_b_c;
  p.spin_min_frames = spin_min_frames;
  w.configure(p);
  addReadings(w, [](double t) { return rvwo::SE2(0.3 * std::min(t, 0.5) + 0.9 * std::max(t - 0.5, 0.0), 0.0, 0.1); });
  EXPECT_TRUE(w.optimisesLocalMaps());
  // One set of points, 3 to 40 m ahead of the standing robot, seen with 1 px noise at level 0.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1), depth(3.0, 40.0);
  std::normal_distribution<double> g(0, 1);
  const Eigen::Isometry3d T_w_c_stand = cameraPose(truth(0.5), T_b_c).inverse();
  std::vector<Eigen::Vector3d> P_w;
  for (int i = 0; i < 200; ++i) {
    const double z = depth(rng);
    const Eigen::Vector2d uv = rvwo::test::drawVector<2>(u, rng);
    P_w.push_back(T_w_c_stand * Eigen::Vector3d(uv.x() * 0.7 * z, uv.y() * 0.5 * z, z));
  }
  const auto see = [&](double t, int i, double noise, PoseMatch* m) {
    const Eigen::Vector3d P_c = cameraPose(truth(t), T_b_c) * P_w[i];
    m->level = i % 3;
    const double s = noise * std::pow(1.2, m->level);
    m->u = 400 * P_c.x() / P_c.z() + 319.5 + s * g(rng);
    m->v = 400 * P_c.y() / P_c.z() + 239.5 + s * g(rng);
    m->u_right = m->u - 48 / P_c.z();
    m->P_w = P_w[i];
    m->id = static_cast<unsigned long>(i);
  };
  // Tracking, 30 frames a second from 0.5 s, each frame from the last one's pose: the first two
  // follow the wheels part of the way (the edge not yet strained), the rest slip.
  int slips = 0;
  Eigen::Isometry3d T_cp_w = cameraPose(truth(0.5), T_b_c);
  for (int k = 1; k <= 12; ++k) {
    PoseProblem f;
    f.fx = f.fy = 400;
    f.cx = 319.5;
    f.cy = 239.5;
    f.bf = 48;
    f.scale_factor = 1.2;
    f.t = 0.5 + k / 30.0;
    f.has_previous = true;
    f.t_previous = 0.5 + (k - 1) / 30.0;
    f.T_cp_w = T_cp_w;
    f.T_c_w = cameraPose(truth(f.t_previous) * rvwo::SE2(0.03, 0.0, 0.0), T_b_c);  // the wheels' prediction
    f.matches.resize(P_w.size());
    for (std::size_t i = 0; i < P_w.size(); ++i) see(f.t, static_cast<int>(i), 1.0, &f.matches[i]);
    PoseSolution s;
    if (!w.optimisePose(f, &s)) return INFINITY;
    w.frameTracked(f.t, true, 200);
    slips += s.slip;
    T_cp_w = s.T_c_w;
  }
  EXPECT_EQ(slips, 10);
  // The local map: keyframes at 0.3 and 0.4 s held, 0.5, 0.7 and 0.9 s free, where tracking put
  // them (the truth), every point seen by each.
  rvwo::orbslam3::LocalMapProblem pb;
  pb.scale_factor = 1.2;
  const std::vector<double> kf_t = {0.3, 0.4, 0.5, 0.7, 0.9};
  for (std::size_t k = 0; k < kf_t.size(); ++k)
    pb.keyframes.push_back({k, kf_t[k], cameraPose(truth(kf_t[k]), T_b_c), k < 2, 400, 400, 319.5, 239.5, 48});
  for (std::size_t i = 0; i < P_w.size(); ++i) pb.points.push_back({1000 + i, P_w[i]});
  for (std::size_t k = 0; k < kf_t.size(); ++k) {
    for (std::size_t i = 0; i < P_w.size(); ++i) {
      PoseMatch m;
      see(kf_t[k], static_cast<int>(i), 0.0, &m);
      pb.observations.push_back({static_cast<int>(k), static_cast<int>(i), m.u, m.v, m.u_right, m.level});
    }
  }
  rvwo::orbslam3::LocalMapSolution out;
  if (!w.optimiseLocalMap(pb, &out)) return INFINITY;
  *wheel_edges = out.wheel_edges;
  double worst = 0;
  for (std::size_t k = 2; k < kf_t.size(); ++k) {
    double off_plane = 1;
    const rvwo::SE2 e = truth(kf_t[k]).inverse() * robotOf(out.T_c_w[k], T_b_c, &off_plane);
    worst = std::max({worst, e.translation().norm(), 10 * std::fabs(e.angle())});  // m, or rad x 10 m
  }
  return worst;
}

// Walkers no label marks, three for every two static points, agree on a pose 2 cm and 20 mrad
// off: the fused pose strains the wheel edge, and vision alone, with them, is no slip. The wheel
// gate (Tracking.WheelGate) solves the frame again from the wheels' prediction and keeps it with
// the static points; without it the walkers drag it. (Walkers within their gate of the truth come
// back with the static points after the first round and pull: at 10 mrad, 4 px at most here, the
// gate left 3 mrad of 10.)
TEST(WheelInputPose, WalkersNoLabelMarksAreHeldOffByTheWheelGate) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  const auto drive = [](double t) { return rvwo::SE2(0.5 * t, 0.0, 0.2 * t); };
  const rvwo::SE2 x_true = drive(0.5);
  StereoFrame f(x_true, T_b_c, 100, 0.0, 21);
  const StereoFrame walkers(x_true * rvwo::SE2(0.0, 0.02, 0.02), T_b_c, 150, 0.0, 22);
  for (PoseMatch m : walkers.problem.matches) {
    m.id += 1000;
    f.problem.matches.push_back(m);
  }
  f.problem.t = 0.5;
  f.problem.has_previous = true;
  f.problem.t_previous = 0.4667;
  f.problem.T_cp_w = cameraPose(drive(f.problem.t_previous), T_b_c);
  f.problem.T_c_w = cameraPose(x_true, T_b_c);  // the wheels' prediction
  double off_plane = 1;
  for (const bool gate : {true, false}) {
    WheelInput w;
    WheelInputParams p;
    p.T_b_c = T_b_c;
    p.tracking.wheel_gate = gate;
    w.configure(p);
    addReadings(w, drive);
    PoseSolution s;
    ASSERT_TRUE(w.optimisePose(f.problem, &s));
    EXPECT_FALSE(s.slip);
    const rvwo::SE2 e = x_true.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane);
    int walkers_in = 0;
    for (std::size_t k = 100; k < s.outlier.size(); ++k) walkers_in += !s.outlier[k];
    if (gate) {
      EXPECT_LT(std::fabs(e.angle()), 1e-3);  // 0.55 mrad here
      EXPECT_LT(e.translation().norm(), 5e-3);
      EXPECT_LT(walkers_in, 20);
    } else {
      EXPECT_GT(std::fabs(e.angle()), 7e-3);  // dragged a third of the way or more
    }
  }
}

TEST(WheelInputLocalMap, AWheelEdgeAcrossASpinLeavesTheKeyframesWhereVisionPutThem) {
  int wheel_edges = -1;
  EXPECT_LT(spinKeyframeError(3, &wheel_edges), 1e-4);  // LocalMapping.SpinMinFrames' default
  EXPECT_EQ(wheel_edges, 1);                            // 0.4 to 0.5 s; not the two across the spin
  // Ten slip frames are no spin to a bar of 11: the edges across them are in the first round
  // (under Huber, as any slipped edge) and pull the keyframes along the wheels' claim.
  EXPECT_GT(spinKeyframeError(11, &wheel_edges), 1e-3);
  EXPECT_EQ(wheel_edges, 3);
}

// After frames on the wheels alone, the wheel edge starts at the last frame vision tracked and
// carries the whole stretch's uncertainty: the wheels' drift over the stretch does not hold the
// frame where vision is back. (From the previous frame, itself the wheels' guess, the edge is
// tight and holds the drift.)
TEST(WheelInputPose, AfterAStretchOnTheWheelsTheEdgeStartsAtTheLastVisualFrame) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  auto truth = [](double t) { return rvwo::SE2(0.5 * t, 0.0, 0.2); };
  // The wheels claim 10 % more distance than driven (a wrong radius): 3.5 cm over 0.7 s.
  auto claimed = [](double t) { return rvwo::SE2(0.55 * t, 0.0, 0.2); };
  WheelInput w;
  configureWheels(w, T_b_c, claimed, false);  // no slip check: the edge alone is under test
  StereoFrame a(truth(0.2), T_b_c, 200, 0.0, 8);
  a.problem.t = 0.2;
  a.problem.T_c_w = cameraPose(truth(0.2), T_b_c);
  PoseSolution s;
  ASSERT_TRUE(w.optimisePose(a.problem, &s));
  w.frameTracked(0.2, true, 1000);
  for (int k = 3; k <= 9; ++k) w.frameTracked(0.1 * k, false, 0);  // blind: the wheels carry it
  // Vision is back at 1.0 with few, near points; the frame before (0.9) sits where the wheels put it.
  const rvwo::SE2 x_09 = truth(0.2) * claimed(0.2).inverse() * claimed(0.9);
  StereoFrame b(truth(1.0), T_b_c, 40, 0.0, 9);
  for (PoseMatch& m : b.problem.matches) {  // keep them near: 1.5 to 3 m
    const Eigen::Isometry3d T_c_w = cameraPose(truth(1.0), T_b_c);
    const Eigen::Vector3d P_c = T_c_w * m.P_w;
    const double f = std::min(1.0, 3.0 / P_c.z());
    m.P_w = T_c_w.inverse() * (P_c * f);
    m.u = 400 * P_c.x() / P_c.z() + 319.5;
    m.v = 400 * P_c.y() / P_c.z() + 239.5;
    m.u_right = m.u - b.problem.bf / (P_c.z() * f);
  }
  b.problem.t = 1.0;
  b.problem.has_previous = true;
  b.problem.t_previous = 0.9;
  b.problem.T_cp_w = cameraPose(x_09, T_b_c);
  b.problem.T_c_w = cameraPose(x_09 * claimed(0.9).inverse() * claimed(1.0), T_b_c);
  ASSERT_TRUE(w.optimisePose(b.problem, &s));
  double off_plane = 1;
  const double error = (truth(1.0).inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm();
  EXPECT_LT(error, 0.008);
  // Tied to the previous frame instead (vision was never lost), the same frame stays with the drift.
  WheelInput tied;
  configureWheels(tied, T_b_c, claimed, false);
  ASSERT_TRUE(tied.optimisePose(b.problem, &s));
  const double tied_error = (truth(1.0).inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm();
  EXPECT_GT(tied_error, 2 * error);
}

// A slow skid: the robot stands while its wheels creep on, 8 mm a frame (0.24 m/s at 30 Hz), each
// frame's claim within what their noise and a few pixels allow. Tracked frame by frame, as ORB-SLAM3
// does (the previous frame's pose as the edge's start, the wheels' prediction as the guess), the
// fused pose followed the creep (the stereo slip scenario at 15 s: 5 cm before any check ran).
// Vision alone's own track over the last half second against the wheels' catches it.
// Returns the worst error; *last: the last frame's.
double creepError(double creep, bool slip_check, std::size_t* slips, double* last) {
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  const rvwo::SE2 still(1.0, 2.0, 0.3);
  auto claimed = [&](double t) { return still * rvwo::SE2(creep * std::max(0.0, t - 0.2), 0, 0); };
  WheelInput w;
  configureWheels(w, T_b_c, claimed, slip_check);
  Eigen::Isometry3d T_cp_w = cameraPose(still, T_b_c);
  double worst = 0;
  for (int k = 0; k < 27; ++k) {  // 0.1 to 0.97 s
    const double t = 0.1 + k / 30.0;
    StereoFrame f(still, T_b_c, 200, 0.05, 100 + k);
    f.problem.t = t;
    f.problem.has_previous = k > 0;
    f.problem.t_previous = t - 1.0 / 30;
    f.problem.T_cp_w = T_cp_w;
    f.problem.T_c_w = k > 0 ? w.predict(T_cp_w, t - 1.0 / 30, t) : T_cp_w;
    PoseSolution s;
    EXPECT_TRUE(w.optimisePose(f.problem, &s));
    w.frameTracked(t, true, 200);
    T_cp_w = s.T_c_w;
    double off_plane = 1;
    *last = (still.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm();
    worst = std::max(worst, *last);
  }
  *slips = w.slipFrames();
  return worst;
}

TEST(WheelInputPose, WheelsThatCreepLoseToVisionWithinAFewFrames) {
  std::size_t slips = 0, none = 0, honest_slips = 0;
  double last = 1, last_followed = 0, last_honest = 1;
  const double caught = creepError(0.24, true, &slips, &last);
  const double followed = creepError(0.24, false, &none, &last_followed);
  const double honest = creepError(0.0, true, &honest_slips, &last_honest);
  std::printf(
      "creep: worst %.4f m, last %.4f m with the check (%zu slip frames); %.4f m, %.4f m without; "
      "honest wheels %.4f m\n",
      caught, last, slips, followed, last_followed, honest);
  EXPECT_EQ(none, 0u);
  // Without the check the pose follows the creep; with it, a few frames of it (until the creep
  // is beyond the map's errors and the calibration), then vision alone brings it back.
  EXPECT_GT(last_followed, 0.018);
  EXPECT_LT(caught, 0.7 * followed);
  EXPECT_LT(last, 0.006);
  // The creep runs over the last 23 frames: most of them, and no other, are slips.
  EXPECT_GE(slips, 18u);
  EXPECT_LE(slips, 23u);
  // Wheels that tell the truth never lose, over 27 frames of vision's noise (the error is the
  // first frame's, placed by vision alone, carried on).
  EXPECT_EQ(honest_slips, 0u);
  EXPECT_LT(honest, 0.007);
}

// ---- labels: keyframes to a segmenter, labels to the map points' reliabilities (eqs. 4, 5)

// Every pixel the background (class 0).
class Background final : public rvwo::Segmenter {
 public:
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    rvwo::Segmentation s;
    s.labels = cv::Mat::zeros(image.rows, image.cols, CV_32S);
    return s;
  }
  const std::vector<std::string>& classNames() const override { return names_; }

 private:
  std::vector<std::string> names_ = rvwo::SemanticPriors::builtin("voc21").classes();
};

TEST(WheelInputLabels, WithASegmenterOnlyLabelledPointsOverruleTheWheels) {
  // The slip above, with a segmenter: until a keyframe's labels reach the points, vision alone
  // does not count against the wheels (a keyframe's new points are often a walker's).
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  const rvwo::SE2 still(1.0, 2.0, 0.3);
  WheelInput w;
  configureWheels(w, T_b_c, [&](double t) { return still * rvwo::SE2(0.6 * t, 0, 0); });
  w.setSegmenter(std::make_shared<Background>());
  StereoFrame f(still, T_b_c, 200, 0.0, 5);
  f.problem.t = 0.5;
  f.problem.has_previous = true;
  f.problem.t_previous = 0.4;
  f.problem.T_cp_w = cameraPose(still, T_b_c);
  f.problem.T_c_w = cameraPose(still * rvwo::SE2(0.06, 0, 0), T_b_c);
  PoseSolution s;
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  EXPECT_FALSE(s.slip);
  // Nor do they place the frame: the wheels do, 6 cm on (vision alone would have it stand).
  double off_plane = 1;
  const rvwo::SE2 claimed = still * rvwo::SE2(0.06, 0, 0);
  EXPECT_LT((claimed.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm(), 0.005);
  // A keyframe labels them static: now they overrule the wheels.
  std::vector<rvwo::orbslam3::KeyFrameFeature> features;
  for (const auto& m : f.problem.matches) features.push_back({static_cast<float>(m.u), static_cast<float>(m.v), m.id});
  w.keyFrame(0.4, cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)), features);
  w.waitForLabels(5.0);
  ASSERT_EQ(w.segmentedKeyFrames(), 1u);
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  EXPECT_TRUE(s.slip);
  EXPECT_LT((still.inverse() * robotOf(s.T_c_w, T_b_c, &off_plane)).translation().norm(), 0.002);
}

// Keeps what each image it was given looked like: its channels and its first pixel.
class Recorder final : public rvwo::Segmenter {
 public:
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    std::lock_guard<std::mutex> lock(mutex);
    seen.push_back(image.channels() == 1 ? cv::Vec3b(image.at<uchar>(0, 0), 0, 0) : image.at<cv::Vec3b>(0, 0));
    channels.push_back(image.channels());
    rvwo::Segmentation s;
    s.labels = cv::Mat::zeros(image.rows, image.cols, CV_32S);
    return s;
  }
  const std::vector<std::string>& classNames() const override { return names_; }
  std::mutex mutex;
  std::vector<int> channels;
  std::vector<cv::Vec3b> seen;

 private:
  std::vector<std::string> names_ = rvwo::SemanticPriors::builtin("voc21").classes();
};

TEST(WheelInputLabels, TheSegmenterSeesTheFramesColourImage) {
  // ORB-SLAM3's keyframe carries its grey image; the network needs the colour one Tracking got.
  WheelInput w;
  WheelInputParams p;
  p.T_b_c = tiltedCamera();
  w.configure(p);
  const cv::Mat grey(480, 640, CV_8U, cv::Scalar(7));
  w.frameImage(cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));  // before a segmenter: not kept
  auto recorder = std::make_shared<Recorder>();
  w.setSegmenter(recorder);
  w.keyFrame(0.0, grey, {});
  cv::Mat colour(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  w.frameImage(colour);
  w.keyFrame(0.1, grey, {});
  w.waitForLabels(5.0);
  colour.setTo(cv::Scalar(0, 0, 0));  // the caller's next frame in the same buffer: the keyframe's was copied
  w.frameImage(cv::Mat(480, 640, CV_8UC4, cv::Scalar(40, 50, 60, 255)));  // BGRA, as ORB-SLAM3 takes it
  w.keyFrame(0.2, grey, {});
  w.waitForLabels(5.0);
  w.frameImage(cv::Mat(240, 320, CV_8UC3, cv::Scalar(70, 80, 90)));  // not the keyframe's image: its grey
  w.keyFrame(0.3, grey, {});
  w.waitForLabels(5.0);
  w.frameImage(grey);  // a grey camera: nothing to keep
  w.keyFrame(0.4, grey, {});
  w.waitForLabels(5.0);
  std::lock_guard<std::mutex> lock(recorder->mutex);
  EXPECT_EQ(recorder->channels, (std::vector<int>{1, 3, 3, 1, 1}));
  ASSERT_EQ(recorder->seen.size(), 5u);
  EXPECT_EQ(recorder->seen[0], cv::Vec3b(7, 0, 0));
  EXPECT_EQ(recorder->seen[1], cv::Vec3b(10, 20, 30));
  EXPECT_EQ(recorder->seen[2], cv::Vec3b(40, 50, 60));
  EXPECT_EQ(recorder->seen[3], cv::Vec3b(7, 0, 0));
  EXPECT_EQ(recorder->seen[4], cv::Vec3b(7, 0, 0));
}

TEST(WheelInputLabels, KeyframeLabelsRejectAWalkersPointsAndKeepTheRest) {
  WheelInput w;
  WheelInputParams p;
  p.T_b_c = tiltedCamera();
  p.label_dilation_px = 0;
  w.configure(p);
  EXPECT_FALSE(w.segments());
  const cv::Mat image(480, 640, CV_8U, cv::Scalar(128));
  // Without a segmenter a keyframe is ignored: every point keeps a fresh one's alpha.
  w.keyFrame(0.0, image, {{100.f, 200.f, 1ul}});
  EXPECT_EQ(w.segmentedKeyFrames(), 0u);
  EXPECT_DOUBLE_EQ(w.alpha(1), 1.0);
  auto segmenter = std::make_shared<HalfPerson>();
  w.setSegmenter(segmenter);
  ASSERT_TRUE(w.segments());
  // Point 1 on the person (left half), point 2 on the background, seen by three keyframes.
  for (int k = 0; k < 3; ++k) {
    w.keyFrame(0.1 * k, image, {{100.f + k, 200.f, 1ul}, {500.f - k, 200.f, 2ul}});
    w.waitForLabels(5.0);
  }
  EXPECT_EQ(w.segmentedKeyFrames(), 3u);
  EXPECT_EQ(segmenter->calls, 3);
  EXPECT_EQ(w.alpha(1), -std::numeric_limits<double>::infinity());  // rejected before it moved
  EXPECT_GT(w.alpha(2), 0.9);                                       // background: trusted
  EXPECT_DOUBLE_EQ(w.alpha(3), 1.0);                                // never labelled: fresh
  // A frame whose matches include the walker's point: it places nothing (an outlier whatever its
  // error), the background does.
  const Eigen::Isometry3d& T_b_c = p.T_b_c;
  StereoFrame f(rvwo::SE2(0.3, 0.1, 0.2), T_b_c, 100, 0.0, 31);
  f.problem.t = 0.5;
  f.problem.T_c_w = cameraPose(rvwo::SE2(0.3, 0.1, 0.2), T_b_c);
  for (PoseMatch& m : f.problem.matches) m.id = m.id == 1 ? 1 : 100 + m.id;
  // Its other points a keyframe saw on the background: labelled, so trusted to place the frame
  // (unlabelled ones would only be judged: a keyframe's new points are often a walker's).
  std::vector<rvwo::orbslam3::KeyFrameFeature> background;
  for (const PoseMatch& m : f.problem.matches)
    if (m.id != 1) background.push_back({500.f, 200.f, m.id});
  w.keyFrame(0.4, image, background);
  w.waitForLabels(5.0);
  PoseSolution s;
  ASSERT_TRUE(w.optimisePose(f.problem, &s));
  EXPECT_TRUE(s.outlier[1]);
  int kept = 0;
  for (std::size_t k = 0; k < s.outlier.size(); ++k) kept += k != 1 && !s.outlier[k];
  EXPECT_GT(kept, 85);
  // Settings: a bad dilation, a network that cannot be read: one error naming the key (and file).
  const std::string path = rvwo::test::scratch("labels.yaml").string();
  auto configureError = [&](const std::string& line) {
    std::ofstream(path) << "%YAML:1.0\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
                           "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
                        << line << "\n";
    try {
      WheelInput bad;
      bad.configure(path);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(configureError("Segmentation.LabelDilation: 2.5").find("Segmentation.LabelDilation"), std::string::npos);
  const std::string model = configureError("Segmentation.Model: \"no_such_model.onnx\"");
  EXPECT_NE(model.find("Segmentation.Model"), std::string::npos) << model;
  EXPECT_NE(model.find("no_such_model.onnx"), std::string::npos) << model;
  std::filesystem::remove(path);
}

// Settings that name no network (Segmentation.Model unset): the one RVWO ships, on a real TUM
// frame: keypoints on the walking person lose their weight, those on the room keep it. "none" and
// a label set the shipped network does not speak are the settings' to say.
TEST(WheelInputLabels, ShippedNetworkLabelsARealWalkerWhenTheSettingsNameNone) {
  const std::string path = rvwo::test::scratch("network.yaml").string();
  auto settingsWith = [&](const std::string& line) {
    std::ofstream(path) << "%YAML:1.0\nCamera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
                           "   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
                        << line << "\n";
    return path;
  };
  {
    WheelInput none;
    none.configure(settingsWith("Segmentation.Model: \"none\""));
    EXPECT_TRUE(none.active());
    EXPECT_FALSE(none.segments());
    WheelInput coco;
    try {
      coco.configure(settingsWith("Semantics.LabelSet: \"coco80\""));
      ADD_FAILURE() << "a coco80 label set took the voc21 network";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("Segmentation.Model: unset, and the network RVWO ships speaks voc21"),
                std::string::npos)
          << e.what();
    }
  }
  WheelInput w;
  w.configure(settingsWith(""));
  std::filesystem::remove(path);
  ASSERT_TRUE(w.segments());
  const std::string shared = RVWO_SHARED_DIR;
  if (!std::filesystem::exists(shared + "/data/tum_fr3_walking_xyz"))
    GTEST_SKIP() << "../shared is absent: no real frame";
  const auto rgb_dir = std::filesystem::path(shared) / "data" / "tum_fr3_walking_xyz" / "rgb";
  const auto frame = *std::filesystem::directory_iterator(rgb_dir);
  const cv::Mat rgb = cv::imread(frame.path().string(), cv::IMREAD_COLOR);
  const cv::Mat mask =
      cv::imread((rgb_dir.parent_path() / "mask" / frame.path().filename()).string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(rgb.empty());
  ASSERT_FALSE(mask.empty());
  // Ten keypoints well inside the person (mask 0, far from its border) and ten well outside.
  cv::Mat person = mask == 0, inside, outside;
  cv::erode(person, inside, cv::Mat(), cv::Point(-1, -1), 15);
  cv::erode(~person, outside, cv::Mat(), cv::Point(-1, -1), 30);
  std::vector<rvwo::orbslam3::KeyFrameFeature> features;
  std::vector<cv::Point> in, out;
  cv::findNonZero(inside, in);
  cv::findNonZero(outside, out);
  ASSERT_GE(in.size(), 10u);
  ASSERT_GE(out.size(), 10u);
  for (int k = 0; k < 10; ++k) {
    const cv::Point a = in[k * in.size() / 10], b = out[k * out.size() / 10];
    features.push_back({float(a.x), float(a.y), 1000ul + k});
    features.push_back({float(b.x), float(b.y), 2000ul + k});
  }
  for (int k = 0; k < 3; ++k) {
    w.keyFrame(0.1 * k, rgb, features);
    w.waitForLabels(30.0);
  }
  EXPECT_EQ(w.segmentedKeyFrames(), 3u);
  int rejected = 0, trusted = 0;
  for (int k = 0; k < 10; ++k) {
    rejected += w.alpha(1000ul + k) == -std::numeric_limits<double>::infinity();
    trusted += w.alpha(2000ul + k) > 0.9;
  }
  EXPECT_GE(rejected, 9);
  EXPECT_GE(trusted, 9);
}

TEST(WheelInputPose, MonocularAndInactiveLeaveItToOrbSlam3) {
  WheelInput none;
  EXPECT_FALSE(none.optimisesPoses());
  WheelInputParams p;
  p.map_from_depth = false;  // mono: the map's scale is not the wheels'
  WheelInput mono;
  mono.configure(p);
  EXPECT_FALSE(mono.optimisesPoses());
  StereoFrame f(rvwo::SE2(), Eigen::Isometry3d::Identity(), 10, 0.0, 1);
  f.problem.t = 0;
  f.problem.T_c_w = Eigen::Isometry3d::Identity();
  PoseSolution s;
  EXPECT_FALSE(mono.optimisePose(f.problem, &s));
  p.map_from_depth = true;
  p.planar = false;
  WheelInput off;
  off.configure(p);
  EXPECT_FALSE(off.optimisesPoses());
}

// ---- a monocular map's first two keyframes against the wheels (monocularScale)

// Mono wheels that saw the robot drive 0.4 m while turning 0.3 rad over [0, 1], and the camera
// poses of their start and end in a two-view map whose unit is `unit` metres, as ORB-SLAM3 makes
// one.
struct TwoViews {
  Eigen::Isometry3d T_b_c;
  WheelInput wheels;
  rvwo::SE2 x0 = rvwo::SE2(1.0, -2.0, 2.9), x1 = x0 * rvwo::SE2(0.39, 0.06, 0.3);
  // seen: the motion the wheels saw (by default the truth, x0 to x1).
  explicit TwoViews(bool mono = true, const rvwo::SE2& seen = rvwo::SE2(0.39, 0.06, 0.3),
                    const Eigen::Isometry3d& T_b_c = tiltedCamera())
      : T_b_c(T_b_c) {
    WheelInputParams p;
    p.T_b_c = T_b_c;
    p.map_from_depth = !mono;
    wheels.configure(p);
    const Eigen::Vector3d xi = seen.log();
    addReadings(wheels, [&](double t) { return x0 * rvwo::SE2::exp(t * xi); });
  }
  // The map's view of a camera pose T_c_w: translations in its unit.
  static Eigen::Isometry3d inMap(Eigen::Isometry3d T_c_w, double unit) {
    T_c_w.translation() /= unit;
    return T_c_w;
  }
  double scale(const Eigen::Isometry3d& T_c1_w_true, double unit) {
    return wheels.monocularScale(0, 1, inMap(cameraPose(x0, T_b_c), unit), inMap(T_c1_w_true, unit));
  }
};

TEST(WheelInputInit, TheWheelsGiveAMonocularMapItsMetres) {
  TwoViews v;
  const Eigen::Isometry3d T_c1_w = cameraPose(v.x1, v.T_b_c);
  for (const double unit : {0.37, 1.0, 4.2}) EXPECT_NEAR(v.scale(T_c1_w, unit), unit, 1e-6 * unit) << unit;
  // ORB-SLAM3's own frame: the first camera at the origin.
  const Eigen::Isometry3d T_c0_w = cameraPose(v.x0, v.T_b_c);
  EXPECT_NEAR(
      v.wheels.monocularScale(0, 1, Eigen::Isometry3d::Identity(), TwoViews::inMap(T_c1_w * T_c0_w.inverse(), 2.5)),
      2.5, 1e-6);
  // Vision's translation a few millimetres off: the scale a little off, not refused.
  Eigen::Isometry3d T_off = T_c1_w;
  T_off.translation() += Eigen::Vector3d(0.004, -0.003, 0.005);
  EXPECT_NEAR(v.scale(T_off, 0.5), 0.5, 0.5 * 0.03);
  // In metres, the map has the wheels' scale: its frames go on SE(2), mono observations (no
  // baseline, no stereo edge) and all.
  ASSERT_TRUE(v.wheels.optimisesPoses());
  StereoFrame f(v.x1, v.T_b_c, 200, 0.0, 5);
  f.problem.bf = 0;
  for (PoseMatch& m : f.problem.matches) m.u_right = -1;
  f.problem.t = 1.0;
  f.problem.T_c_w = cameraPose(v.x1 * rvwo::SE2(0.03, 0.02, 0.02), v.T_b_c);
  PoseSolution solution;
  ASSERT_TRUE(v.wheels.optimisePose(f.problem, &solution));
  double off_plane = 1;
  const rvwo::SE2 e = v.x1.inverse() * robotOf(solution.T_c_w, v.T_b_c, &off_plane);
  EXPECT_LT(e.translation().norm(), 0.005);
  EXPECT_LT(std::fabs(e.angle()), 0.002);
  // With a segmenter too, though no label has reached these points (a mono map's are
  // triangulated after their keyframes were segmented): labels only reject there.
  v.wheels.setSegmenter(std::make_shared<Background>());
  ASSERT_TRUE(v.wheels.optimisePose(f.problem, &solution));
  EXPECT_LT((v.x1.inverse() * robotOf(solution.T_c_w, v.T_b_c, &off_plane)).translation().norm(), 0.005);
}

// Frames the wheels carry (vision lost the map) become keyframes, as stereo ones do, once the
// map is in metres: one each 0.15 m of the wheels, for the parallax new points need, which local
// mapping triangulates against the keyframes before it in time (it shares no point yet).
std::vector<int> monoKeyframesOnTheWheels(TwoViews& v) {
  std::vector<int> asked;
  for (int k = 0; k <= 20; ++k) {  // the wheels drive 0.40 m in the second
    v.wheels.frameTracked(0.05 * k, k < 2, k == 18 ? 100 : 800);
    if (v.wheels.keyFrameNeeded()) asked.push_back(k);
  }
  return asked;
}

TEST(WheelInputInit, AMonocularMapInMetresGrowsFromKeyframesOnTheWheels) {
  TwoViews before;  // not in metres: a keyframe of its could not place its points
  EXPECT_FALSE(before.wheels.triangulatesInTime());
  EXPECT_TRUE(monoKeyframesOnTheWheels(before).empty());
  TwoViews v;
  ASSERT_NEAR(v.scale(cameraPose(v.x1, v.T_b_c), 1.0), 1.0, 1e-6);
  EXPECT_TRUE(v.wheels.triangulatesInTime());
  // On the wheels from 0.1 s: 0.15 m at 0.48 s (frame 10), then at 0.88 s, but frame 18 sees too little
  // (100 features), and the next one goes.
  EXPECT_EQ(monoKeyframesOnTheWheels(v), (std::vector<int>{10, 19}));
  // A travel of nothing would make every frame a keyframe: refused.
  WheelInputParams p;
  p.mono_keyframe_travel = 0.0;
  WheelInput bad;
  EXPECT_THROW(bad.configure(p), std::invalid_argument);
}

TEST(WheelInputInit, AMonocularRobotThatStoodAMinuteOnTheWheelsStillGrowsItsMap) {
  TwoViews v;
  ASSERT_NEAR(v.scale(cameraPose(v.x1, v.T_b_c), 1.0), 1.0, 1e-6);
  // After the two views: 70 s standing at x1, then straight on at 0.4 m/s. The wheels keep a
  // minute of readings, so the travel since the run began must not be asked of them.
  std::vector<WheelReading> readings;
  for (int k = 101; k <= 7300; ++k) {
    const double t = 0.01 * k;
    const rvwo::SE2 x = v.x1 * rvwo::SE2(std::max(0.0, 0.4 * (t - 71.0)), 0.0, 0.0);
    readings.push_back(WheelReading::pose(t, x.translation().x(), x.translation().y(), x.angle()));
  }
  v.wheels.add(readings);
  std::vector<int> asked;
  for (int k = 0; k <= 1440; ++k) {  // frames at 20 Hz; on the wheels from frame 2 (0.1 s)
    v.wheels.frameTracked(0.05 * k, k < 2, 800);
    if (v.wheels.keyFrameNeeded()) asked.push_back(k);
  }
  // Each 0.15 m of the wheels: at frames 10 and 18 of the first second's drive, none standing,
  // then driving on from 71 s with the 0.04 m after frame 18 counted, at 71.275 s (frame 1426)
  // and 0.375 s later (frame 1434).
  EXPECT_EQ(asked, (std::vector<int>{10, 18, 1426, 1434}));
}

TEST(WheelInputInit, AMapTheWheelsContradictIsRefused) {
  TwoViews v;
  const Eigen::Isometry3d T_c1_w = cameraPose(v.x1, v.T_b_c);
  // Turned 0.1 rad more than the wheels, or pitched 0.1 rad: off the floor.
  EXPECT_EQ(v.scale(cameraPose(v.x0 * rvwo::SE2(0.39, 0.06, 0.4), v.T_b_c), 1.0), 0.0);
  const Eigen::Isometry3d pitched = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()) * T_c1_w;
  EXPECT_EQ(v.scale(pitched, 1.0), 0.0);
  // Travel sideways, or backwards (mono's two-fold ambiguity; with the camera over the axle, a
  // negative scale would explain it exactly).
  EXPECT_EQ(v.scale(cameraPose(v.x0 * rvwo::SE2(0.06, 0.39, 0.3), v.T_b_c), 1.0), 0.0);
  Eigen::Isometry3d over_axle = tiltedCamera();
  over_axle.translation().setZero();
  TwoViews axle(true, rvwo::SE2(0.39, 0.06, 0.3), over_axle);
  EXPECT_EQ(axle.scale(cameraPose(axle.x0 * rvwo::SE2(-0.39, -0.06, 0.3), axle.T_b_c), 1.0), 0.0);
  EXPECT_NEAR(axle.scale(cameraPose(axle.x1, axle.T_b_c), 1.0), 1.0, 1e-6);
  // Nearly a turn in place (2 cm), and vision agrees: too short a baseline for a map.
  const rvwo::SE2 turn(0.02, 0.0, 0.3);
  TwoViews spin(true, turn);
  EXPECT_EQ(spin.scale(cameraPose(spin.x0 * turn, spin.T_b_c), 1.0), 0.0);
  // A map refused after one in metres: its successor's scale is not known to be the wheels'.
  EXPECT_TRUE(axle.wheels.optimisesPoses());
  EXPECT_EQ(axle.scale(cameraPose(axle.x0 * rvwo::SE2(-0.39, -0.06, 0.3), axle.T_b_c), 1.0), 0.0);
  EXPECT_FALSE(axle.wheels.optimisesPoses());
}

TEST(WheelInputInit, NoAnswerWithoutMonoWheelsThatCoverTheTwoViews) {
  TwoViews v, stereo(false);
  const Eigen::Isometry3d T_c0_w = cameraPose(v.x0, v.T_b_c), T_c1_w = cameraPose(v.x1, v.T_b_c);
  EXPECT_EQ(v.wheels.monocularScale(0.5, 1.5, T_c0_w, T_c1_w), -1.0);  // beyond the readings
  EXPECT_FALSE(v.wheels.optimisesPoses());
  EXPECT_EQ(stereo.scale(T_c1_w, 1.0), -1.0);  // a stereo map is in metres already
  EXPECT_TRUE(stereo.wheels.optimisesPoses());
  EXPECT_EQ(WheelInput().monocularScale(0, 1, T_c0_w, T_c1_w), -1.0);
}

}  // namespace
