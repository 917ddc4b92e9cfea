// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// The plugin without wheels (Odometry.Input: "none"; decision 0022): RVWO's vision alone in
// ORB-SLAM3's 6-DoF tracking. It reads the key, answers optimisePose for any sensor and leaves
// local mapping and loop closing to ORB-SLAM3; it places a tilted, rolled camera through outliers,
// with points awaiting their labels too; and a walker's points, once labelled, no longer drag the
// pose, as they do without labels.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "../common/temp.h"
#include "orbslam3_segmenters.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/orbslam3/wheel_input.h"
#include "rvwo/semantics/segmenter.h"

namespace {

using rvwo::test::HalfPerson;

using rvwo::orbslam3::PoseMatch;
using rvwo::orbslam3::PoseProblem;
using rvwo::orbslam3::PoseSolution;
using rvwo::orbslam3::WheelInput;
using rvwo::orbslam3::WheelReading;

// A camera 1.4 m up, pitched and rolled as a hand-held one is, somewhere in ORB-SLAM3's world.
Eigen::Isometry3d handHeld() {
  Eigen::Isometry3d T_c_w = Eigen::Isometry3d::Identity();
  T_c_w.linear() =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  T_c_w.translation() = Eigen::Vector3d(0.3, -1.4, 2.0);
  return T_c_w;
}

// n RGB-D matches seen from T_c_w (1 px noise at level 0); a fraction 30 px off.
PoseProblem frame(const Eigen::Isometry3d& T_c_w, int n, double outliers, unsigned seed, std::vector<char>* bad) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), depth(1.0, 6.0), coin(0, 1);
  std::normal_distribution<double> g(0, 1);
  PoseProblem p;
  p.t = 1.0;
  p.has_previous = false;
  p.t_previous = 0;
  p.fx = p.fy = 525;
  p.cx = 319.5;
  p.cy = 239.5;
  p.bf = 40;
  p.scale_factor = 1.2;
  for (int k = 0; k < n; ++k) {
    const double z = depth(rng);
    const Eigen::Vector3d P_c(u(rng) * 0.55 * z, u(rng) * 0.42 * z, z);
    PoseMatch m;
    m.P_w = T_c_w.inverse() * P_c;
    m.level = k % 3;
    const double s = std::pow(1.2, m.level);
    m.u = 525 * P_c.x() / z + 319.5 + s * g(rng);
    m.v = 525 * P_c.y() / z + 239.5 + s * g(rng);
    m.u_right = m.u - p.bf / z;
    bad->push_back(coin(rng) < outliers);
    if (bad->back()) m.u += 30, m.u_right += 30;
    m.id = static_cast<unsigned long>(k);
    p.matches.push_back(m);
  }
  return p;
}

double rotationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

Eigen::Isometry3d offBy(const Eigen::Isometry3d& T, double metres, double radians) {
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() = Eigen::AngleAxisd(radians, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  d.translation() = Eigen::Vector3d(1, -1, 1).normalized() * metres;
  return d * T;
}

void configureWithoutWheels(WheelInput& w, const std::string& sensor) {
  const auto path = rvwo::test::scratch("orbslam3_vision.yaml");
  std::ofstream(path) << "%YAML:1.0\nSensor: \"" << sensor
                      << "\"\nOdometry.Input: \"none\"\nSegmentation.Model: \"none\"\n";
  w.configure(path.string());
}

TEST(WheelInputVision, OdometryInputNoneRunsVisionAloneForAnySensor) {
  for (const char* sensor : {"stereo", "mono"}) {
    WheelInput w;
    configureWithoutWheels(w, sensor);  // no Camera.T_b_c, no wheels' size: none is needed
    ASSERT_TRUE(w.active()) << sensor;
    EXPECT_TRUE(w.optimisesPoses()) << sensor;  // mono too: no map in metres is needed
    EXPECT_FALSE(w.optimisesLocalMaps()) << sensor;
    EXPECT_FALSE(w.optimisesEssentialGraphs()) << sensor;
    EXPECT_FALSE(w.covers(0.0, 1.0));
    EXPECT_EQ(w.monocularScale(0.0, 1.0, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()), -1.0);
    w.add({});  // the Track* overloads without readings
    try {
      w.add({WheelReading::pose(0.0, 0, 0, 0)});
      FAIL() << "a reading taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "wheel readings given, but the settings say Odometry.Input: \"none\"");
    }
    for (int k = 0; k < 5; ++k) w.frameTracked(k, false, 1000);
    EXPECT_FALSE(w.keyFrameNeeded());     // nothing carries a lost frame
    EXPECT_TRUE(w.keyFrameWanted(true));  // ORB-SLAM3's own wish, as it is
    EXPECT_FALSE(w.keyFrameWanted(false));
  }
}

// Through outliers, with no segmenter, and with one whose labels have not come yet (no point is
// trusted): without wheels nothing else holds the frame, so then every point not rejected places
// it, and what fits the pose is kept (an outlier ORB-SLAM3 would drop, and lose tracking for want
// of inliers).
TEST(WheelInputVision, PlacesAHandHeldCameraIn6DofThroughOutliers) {
  for (const bool awaiting_labels : {false, true}) {
    WheelInput w;
    configureWithoutWheels(w, "stereo");
    if (awaiting_labels) w.setSegmenter(std::make_shared<HalfPerson>());
    const Eigen::Isometry3d truth = handHeld();
    std::vector<char> bad;
    PoseProblem p = frame(truth, 250, 0.15, awaiting_labels ? 12 : 4, &bad);
    p.T_c_w = offBy(truth, 0.1, 0.05);
    PoseSolution s;
    ASSERT_TRUE(w.optimisePose(p, &s));
    EXPECT_LT((s.T_c_w.translation() - truth.translation()).norm(), 0.01) << awaiting_labels;
    EXPECT_LT(rotationError(s.T_c_w, truth), 2e-3) << awaiting_labels;
    int good = 0, kept = 0;
    for (std::size_t k = 0; k < bad.size(); ++k) {
      if (bad[k]) EXPECT_TRUE(s.outlier[k]) << k;
      good += !bad[k];
      kept += !bad[k] && !s.outlier[k];
    }
    EXPECT_GT(kept, 0.85 * good);
    EXPECT_EQ(s.inliers, kept);
    EXPECT_FALSE(s.slip);
  }
}

TEST(WheelInputVision, LabelledWalkersNoLongerDragThePose) {
  const Eigen::Isometry3d truth = handHeld();
  std::vector<char> bad;
  const PoseProblem still = frame(truth, 300, 0.0, 9, &bad);
  // The walker: every point on the left half of the image has moved 8 cm with it since it was mapped.
  PoseProblem walked = still;
  for (PoseMatch& m : walked.matches) {
    if (m.u < 320) m.P_w += truth.linear().transpose() * Eigen::Vector3d(0.08, 0.0, 0.0);
  }
  walked.T_c_w = offBy(truth, 0.03, 0.01);
  auto solve = [&](bool labels) {
    WheelInput w;
    configureWithoutWheels(w, "stereo");
    if (labels) {
      w.setSegmenter(std::make_shared<HalfPerson>());
      std::vector<rvwo::orbslam3::KeyFrameFeature> features;
      for (const PoseMatch& m : still.matches)
        features.push_back({static_cast<float>(m.u), static_cast<float>(m.v), m.id});
      for (int k = 0; k < 3; ++k) {
        w.keyFrame(0.1 * k, cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)), features);
        w.waitForLabels(5.0);
      }
      EXPECT_EQ(w.segmentedKeyFrames(), 3u);
    }
    PoseSolution s;
    EXPECT_TRUE(w.optimisePose(walked, &s));
    return s;
  };
  const PoseSolution unlabelled = solve(false), labelled = solve(true);
  const double dragged = (unlabelled.T_c_w.translation() - truth.translation()).norm();
  const double kept = (labelled.T_c_w.translation() - truth.translation()).norm();
  std::printf("[ figures  ] a walker's points moved 8 cm: pose off by %.4f m unlabelled, %.4f m labelled\n", dragged,
              kept);
  EXPECT_GT(dragged, 0.01);
  EXPECT_LT(kept, 0.005);
  EXPECT_LT(rotationError(labelled.T_c_w, truth), 2e-3);
  for (std::size_t k = 0; k < walked.matches.size(); ++k) {
    if (walked.matches[k].u < 300) EXPECT_TRUE(labelled.outlier[k]) << k;  // never inliers: rejected
  }
}

}  // namespace
