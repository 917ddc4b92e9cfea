// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// Loop closing's pose graph on SE(2) (rvwo/orbslam3/essential_graph.h) on stand-ins for
// ORB-SLAM3's KeyFrame, MapPoint, Map and g2o::Sim3 with the members it uses: a drive around a
// circle whose vision drifted, closed by a loop at its start.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <vector>

#include "orbslam3_common.h"
#include "rvwo/edges/se2.h"
#include "rvwo/orbslam3/essential_graph.h"

namespace {

using rvwo::SE2;
using rvwo::orbslam3::isometryOf;
using rvwo::orbslam3::WheelInput;
using rvwo::orbslam3::WheelInputParams;
using rvwo::orbslam3::WheelReading;
using rvwo::test::cameraPose;
using rvwo::test::Pose;

// As g2o::Sim3 (ORB-SLAM3's bundled g2o): S_c_w = [s R, t].
struct Sim3 {
  explicit Sim3(const Eigen::Isometry3d& T, double s = 1.0) : q(T.linear()), t(s * T.translation()), s(s) {}
  Eigen::Quaterniond rotation() const { return q; }
  Eigen::Vector3d translation() const { return t; }
  double scale() const { return s; }
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  double s;
};

struct KeyFrame {
  unsigned long mnId = 0;
  double mTimeStamp = 0;
  const void* mpCamera2 = nullptr;
  rvwo::test::Camera* mpCamera = rvwo::test::pinholeCamera();
  Pose pose;
  KeyFrame* parent = nullptr;
  std::set<KeyFrame*> children, loops;
  std::map<KeyFrame*, int> weights;  // covisibility: shared points
  bool isBad() const { return false; }
  Pose GetPose() const { return pose; }
  void SetPose(const Pose& p) { pose = p; }
  KeyFrame* GetParent() const { return parent; }
  bool hasChild(KeyFrame* k) const { return children.count(k) > 0; }
  std::set<KeyFrame*> GetLoopEdges() const { return loops; }
  int GetWeight(KeyFrame* k) const { return weights.count(k) ? weights.at(k) : 0; }
  std::vector<KeyFrame*> GetCovisiblesByWeight(int w) const {
    std::vector<KeyFrame*> out;
    for (const auto& [k, n] : weights)
      if (n >= w) out.push_back(k);
    return out;
  }
};

struct MapPoint {
  unsigned long mnCorrectedByKF = 0, mnCorrectedReference = 0;
  KeyFrame* reference = nullptr;
  Eigen::Vector3f P = Eigen::Vector3f::Zero();
  int updates = 0;
  bool isBad() const { return false; }
  KeyFrame* GetReferenceKeyFrame() const { return reference; }
  Eigen::Vector3f GetWorldPos() const { return P; }
  void SetWorldPos(const Eigen::Vector3f& p) { P = p; }
  void UpdateNormalAndDepth() { ++updates; }
};

struct Map : rvwo::test::MapOf<KeyFrame, MapPoint> {};

using Poses = std::map<KeyFrame*, Sim3>;
using Connections = std::map<KeyFrame*, std::set<KeyFrame*>>;

// Once around a circle of 2 m radius in 40 s, through theta = +-pi at 20 s.
constexpr double kOmega = 2 * M_PI / 40;
SE2 drive(double t) { return SE2(2 * std::sin(kOmega * t), 2 * (1 - std::cos(kOmega * t)), kOmega * t); }

// 81 keyframes 0.5 s apart, the last back where the first was. Vision drifted on the way (each
// step 1 mrad and a few mm off, and the poses 1 cm and 0.5 deg off the plane); the loop found
// keyframe 80 at its true pose, and ORB-SLAM3 moved 76 to 80 with it (CorrectedSim3).
struct Circle {
  static constexpr int kKeyFrames = 81, kCurrent = 80, kCorrectedFrom = 76;
  Eigen::Isometry3d T_b_c = rvwo::test::tiltedCamera();
  Map map;
  std::vector<std::unique_ptr<KeyFrame>> kfs;
  std::vector<std::unique_ptr<MapPoint>> mps;
  std::vector<Eigen::Isometry3d> drifted;  // T_c_w before the correction
  Poses non_corrected, corrected;
  Connections connections;
  WheelInput wheels;
  MapPoint* fused = nullptr;

  // How the wheels' readings reach the plugin: none, all before the loop, or as tracking gives
  // them (each keyframe's, then its frame tracked, which drops readings over 20 s old, and its
  // local map).
  enum Readings { kNone, kAll, kAsTracked };
  // vision_sigma: what vision's relative poses claim (m and rad alike), else the default.
  explicit Circle(Readings with_readings, double vision_sigma = 0, bool essential_graph = true) {
    WheelInputParams p;
    p.T_b_c = T_b_c;
    p.essential_graph = essential_graph;
    p.calibrate = false;  // the local maps below have no points to learn it from
    if (vision_sigma > 0) p.graph_sigma_xy = p.graph_sigma_yaw = vision_sigma;
    wheels.configure(p);
    std::vector<WheelReading> readings;
    for (int k = 0; k <= 4000; ++k) {
      const SE2 x = drive(0.01 * k);
      readings.push_back(WheelReading::pose(0.01 * k, x.translation().x(), x.translation().y(), x.angle()));
    }
    if (with_readings == kAll) wheels.add(readings);

    std::mt19937_64 rng(3);
    std::normal_distribution<double> g(0, 1);
    SE2 x = drive(0);
    for (int k = 0; k < kKeyFrames; ++k) {
      if (k > 0) {
        const Eigen::Vector3d step = (drive(0.5 * (k - 1)).inverse() * drive(0.5 * k)).log();
        const Eigen::Vector2d n = rvwo::test::drawVector<2>(g, rng);
        x = x * SE2::exp(Eigen::Vector3d(1.015 * step.x() + 0.002 * n.x(), step.y() + 0.002 * n.y(), step.z() + 0.001));
      }
      Eigen::Isometry3d T = cameraPose(x, T_b_c);
      if (k > 0)
        T = Eigen::AngleAxisd(0.5 * M_PI / 180, Eigen::Vector3d::UnitZ()) * T * Eigen::Translation3d(0, 0.01, 0);
      drifted.push_back(T);
      kfs.push_back(std::make_unique<KeyFrame>());
      KeyFrame& kf = *kfs.back();
      kf.mnId = static_cast<unsigned long>(k);
      kf.mTimeStamp = 0.5 * k;
      kf.pose = rvwo::orbslam3::poseOf<Pose>(T);
      map.keyframes.push_back(&kf);
      if (k > 0) {
        kf.parent = kfs[k - 1].get();
        kfs[k - 1]->children.insert(&kf);
      }
      for (int d = 1; d <= 3 && d <= k; ++d) {  // 3 apart: too few shared points for the graph
        kf.weights[kfs[k - d].get()] = d < 3 ? 200 : 50;
        kfs[k - d]->weights[&kf] = d < 3 ? 200 : 50;
      }
    }
    if (with_readings == kAsTracked) {
      std::size_t r = 0;
      for (int k = 0; k < kKeyFrames; ++k) {
        std::vector<WheelReading> since;
        for (; r < readings.size() && readings[r].t <= kfs[k]->mTimeStamp + 1e-9; ++r) since.push_back(readings[r]);
        wheels.add(since);
        wheels.frameTracked(kfs[k]->mTimeStamp, true, 1000);
        if (k == 0) continue;
        rvwo::orbslam3::LocalMapProblem local;
        for (int j : {k - 1, k})
          local.keyframes.push_back({kfs[j]->mnId, kfs[j]->mTimeStamp, drifted[j], j < k, 500, 500, 320, 240, 40});
        local.scale_factor = 1.2;
        rvwo::orbslam3::LocalMapSolution solution;
        EXPECT_TRUE(wheels.optimiseLocalMap(local, &solution));
        EXPECT_EQ(solution.wheel_edges, 1) << k;
      }
      EXPECT_FALSE(wheels.covers(0.0, 19.0));  // the readings kept: the last 20 s
    }
    // The loop: 80 seen from 0 where it truly is; its neighbours moved with it.
    const Eigen::Isometry3d T_c80_w = cameraPose(drive(0.5 * kCurrent), T_b_c);
    for (int k = kCorrectedFrom; k < kKeyFrames; ++k) {
      const Eigen::Isometry3d T = drifted[k] * drifted[kCurrent].inverse() * T_c80_w;
      corrected.emplace(kfs[k].get(), Sim3(T));
      non_corrected.emplace(kfs[k].get(), Sim3(drifted[k]));
      kfs[k]->pose = rvwo::orbslam3::poseOf<Pose>(T);
    }
    KeyFrame *k0 = kfs[0].get(), *k1 = kfs[1].get(), *k79 = kfs[79].get(), *k80 = kfs[kCurrent].get();
    // The loop's own pair joins whatever it shares; the other new connections share too few
    // points: the loop holds by that one edge.
    k80->weights[k0] = 30;
    k80->weights[k1] = 60;
    k79->weights[k0] = 80;
    connections[k80] = {k0, k1};
    connections[k79] = {k0};

    // Points 1 to 4 m ahead of each keyframe, referred to it. One the loop fused: referred to 78.
    std::uniform_real_distribution<double> u(-1, 1);
    for (int k = 0; k < kKeyFrames; ++k)
      for (int i = 0; i < 3; ++i) {
        mps.push_back(std::make_unique<MapPoint>());
        MapPoint& mp = *mps.back();
        mp.reference = kfs[k].get();
        const double z = 2.5 + 1.5 * u(rng);
        const Eigen::Vector2d uv = rvwo::test::drawVector<2>(u, rng);
        mp.P = (isometryOf(kfs[k]->pose).inverse() * Eigen::Vector3d(uv.x() * z / 2, uv.y() * z / 3, z)).cast<float>();
        map.points.push_back(&mp);
      }
    fused = mps[3 * 10].get();  // referred to keyframe 10
    fused->mnCorrectedByKF = kCurrent;
    fused->mnCorrectedReference = 78;
    fused->P = (isometryOf(kfs[78]->pose).inverse() * Eigen::Vector3d(0.2, -0.1, 3)).cast<float>();
  }

  bool close() {
    return rvwo::orbslam3::optimiseEssentialGraph(wheels, &map, kfs[0].get(), kfs[kCurrent].get(), non_corrected,
                                                  corrected, connections);
  }
  // Position RMS [m] and largest heading error [rad] against the drive; largest off the plane.
  void errors(double* rms, double* yaw, double* off_plane) const {
    double sum = 0;
    *yaw = *off_plane = 0;
    for (int k = 0; k < kKeyFrames; ++k) {
      double off = 0;
      const SE2 e = drive(0.5 * k).inverse() * rvwo::test::robotOf(isometryOf(kfs[k]->pose), T_b_c, &off);
      sum += e.translation().squaredNorm();
      *yaw = std::max(*yaw, std::fabs(e.angle()));
      *off_plane = std::max(*off_plane, off);
    }
    *rms = std::sqrt(sum / kKeyFrames);
  }
};

TEST(EssentialGraph, WheelsAndVisionShareTheLoopsCorrectionByTheirCovariances) {
  // Vision that claims about twice what it drifted (the default) outweighs the wheels (the
  // defaults' 8 mm and 7 mrad a keyframe here): they take a little of the correction. Vision that
  // claims 5 cm and 50 mrad a keyframe leaves the shape to the wheels, which saw it as it was:
  // even a scale error, which a loop cannot see, goes.
  for (const double vision_sigma : {0.0, 0.05}) {
    Circle with(Circle::kAll, vision_sigma), without(Circle::kNone, vision_sigma);
    double rms0, yaw0, off0;
    with.errors(&rms0, &yaw0, &off0);
    ASSERT_GT(rms0, 0.08);  // the drift the loop corrects
    ASSERT_GT(off0, 0.005);
    const Pose first = with.kfs[0]->pose;
    ASSERT_TRUE(with.close());
    ASSERT_TRUE(without.close());
    double rms_w, yaw_w, off_w, rms_v, yaw_v, off_v;
    with.errors(&rms_w, &yaw_w, &off_w);
    without.errors(&rms_v, &yaw_v, &off_v);
    EXPECT_LT(rms_v, 0.45 * rms0) << vision_sigma;  // the loop alone spreads its error evenly
    if (vision_sigma == 0) {
      EXPECT_LT(rms_w, 0.98 * rms_v);
      EXPECT_GT(rms_w, 0.8 * rms_v);
      EXPECT_LE(yaw_w, yaw_v);
    } else {
      EXPECT_LT(rms_w, 0.3 * rms_v);
      EXPECT_LT(rms_w, 0.01);
      EXPECT_LT(yaw_w, 0.5 * yaw_v);
    }
    EXPECT_LT(off_w, 1e-5) << vision_sigma;  // a loop does not tilt the map, whatever the poses had
    EXPECT_LT(off_v, 1e-5) << vision_sigma;
    EXPECT_EQ((with.kfs[0]->pose.t - first.t).norm(), 0.0f);  // the map's first is held
    EXPECT_EQ(with.map.changes, 1);
  }
}

TEST(EssentialGraph, KeyframesKeepTheirWheelsAfterTheReadingsAreDropped) {
  // Tracking keeps the last 20 s of readings; each keyframe's delta from the one before, taken
  // when its local map was solved, stays for the whole map. The loop's graph then has wheel edges
  // around the whole circle, as with every reading kept, and leaves the shape to them as there.
  for (const double vision_sigma : {0.0, 0.05}) {
    Circle tracked(Circle::kAsTracked, vision_sigma), all(Circle::kAll, vision_sigma);
    ASSERT_TRUE(tracked.close());
    ASSERT_TRUE(all.close());
    double rms_t, yaw_t, off_t, rms_a, yaw_a, off_a;
    tracked.errors(&rms_t, &yaw_t, &off_t);
    all.errors(&rms_a, &yaw_a, &off_a);
    EXPECT_NEAR(rms_t, rms_a, 1e-6) << vision_sigma;
    EXPECT_NEAR(yaw_t, yaw_a, 1e-6) << vision_sigma;
    for (int k = 0; k < Circle::kKeyFrames; ++k) {
      EXPECT_LT((tracked.kfs[k]->pose.t - all.kfs[k]->pose.t).norm(), 1e-5f) << vision_sigma << " " << k;
    }
    if (vision_sigma > 0) {
      EXPECT_LT(rms_t, 0.01);
    }
  }
}

TEST(EssentialGraph, PointsMoveWithTheirReferenceKeyframe) {
  Circle circle(Circle::kAll);
  // Each point in its reference keyframe's camera, from the pose the graph starts at (the
  // corrected one near the loop); the fused point in the loop's reference, keyframe 78.
  std::vector<Eigen::Vector3d> in_camera;
  for (const auto& mp : circle.mps) {
    const KeyFrame* r = mp.get() == circle.fused ? circle.kfs[78].get() : mp->reference;
    in_camera.push_back(isometryOf(r->pose) * mp->P.cast<double>());
  }
  const Eigen::Vector3f fused_before = circle.fused->P;
  ASSERT_TRUE(circle.close());
  for (std::size_t i = 0; i < circle.mps.size(); ++i) {
    const MapPoint& mp = *circle.mps[i];
    const KeyFrame* r = &mp == circle.fused ? circle.kfs[78].get() : mp.reference;
    EXPECT_LT((isometryOf(r->pose) * mp.P.cast<double>() - in_camera[i]).norm(), 1e-4) << i;
    EXPECT_EQ(mp.updates, 1) << i;
  }
  // Its own reference (keyframe 10) moved differently: the loop's reference was used.
  EXPECT_GT((circle.fused->P - fused_before).norm(), 0.005f);
}

TEST(EssentialGraph, LeftToOrbSlam3WhenOffOrNotPlanar) {
  Circle off(Circle::kAll, 0, false), rig(Circle::kAll);
  rig.kfs[Circle::kCurrent]->mpCamera2 = &rig;  // two cameras: ORB-SLAM3's own
  Circle fisheye(Circle::kAll);
  fisheye.kfs[Circle::kCurrent]->mpCamera = rvwo::test::fisheyeCamera();  // distorted keypoints: its own too
  const Pose p = off.kfs[40]->pose;
  EXPECT_FALSE(off.close());
  EXPECT_FALSE(rig.close());
  EXPECT_FALSE(fisheye.close());
  EXPECT_EQ((off.kfs[40]->pose.t - p.t).norm(), 0.0f);
  EXPECT_EQ(off.map.changes, 0);
  WheelInput none;  // no RVWO keys: upstream's
  EXPECT_FALSE(rvwo::orbslam3::optimiseEssentialGraph(none, &off.map, off.kfs[0].get(), off.kfs[80].get(),
                                                      off.non_corrected, off.corrected, off.connections));
}

}  // namespace
