// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// The local map on SE(2) (rvwo/orbslam3/local_map.h) on stand-ins for ORB-SLAM3's KeyFrame,
// MapPoint and Map with the members it uses: which keyframes it frees and fixes, what it
// recovers, what it erases and writes back. And vision finding the old map after a blackout
// (rvwo/orbslam3/reacquire.h, pose.h) on stand-ins for Frame and ORBmatcher.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core/types.hpp>
#include <optional>
#include <random>
#include <set>
#include <thread>
#include <tuple>
#include <vector>

#include "orbslam3_common.h"
#include "rvwo/edges/se2.h"
#include "rvwo/orbslam3/local_map.h"
#include "rvwo/orbslam3/pose.h"
#include "rvwo/orbslam3/reacquire.h"

namespace {

using rvwo::orbslam3::WheelInput;
using rvwo::orbslam3::WheelInputParams;
using rvwo::orbslam3::WheelReading;
using rvwo::test::cameraPose;
using rvwo::test::Pose;
using rvwo::test::tiltedCamera;

struct Map;
struct MapPoint;

struct KeyFrame {
  unsigned long mnId = 0, mnBALocalForKF = 0, mnBAFixedForKF = 0, mnBAGlobalForKF = 0;
  double mTimeStamp = 0;
  const void* mpCamera2 = nullptr;
  rvwo::test::Camera* mpCamera = rvwo::test::pinholeCamera();
  float fx = 400, fy = 400, cx = 319.5f, cy = 239.5f, mbf = 48, mfScaleFactor = 1.2f;
  std::vector<cv::KeyPoint> mvKeysUn;
  std::vector<float> mvuRight;
  std::vector<MapPoint*> matches;
  std::vector<KeyFrame*> covisible;
  Map* map = nullptr;
  Pose pose, mTcwGBA;
  std::vector<MapPoint*> GetMapPointMatches() const { return matches; }
  std::vector<KeyFrame*> GetVectorCovisibleKeyFrames() const { return covisible; }
  std::vector<KeyFrame*> GetBestCovisibilityKeyFrames(int n) const {
    return {covisible.begin(), covisible.begin() + std::min<std::size_t>(covisible.size(), n)};
  }
  bool isBad() const { return false; }
  Map* GetMap() const { return map; }
  Pose GetPose() const { return pose; }
  void SetPose(const Pose& p) { pose = p; }
  void EraseMapPointMatch(MapPoint* mp) {
    for (MapPoint*& m : matches)
      if (m == mp) m = nullptr;
  }
};

struct MapPoint {
  inline static std::mutex mGlobalMutex;
  unsigned long mnId = 0, mnBALocalForKF = 0, mnBAGlobalForKF = 0;
  Eigen::Vector3f P = Eigen::Vector3f::Zero(), mPosGBA = Eigen::Vector3f::Zero();
  std::map<KeyFrame*, std::tuple<int, int>> observations;
  Map* map = nullptr;
  int updates = 0;
  std::map<KeyFrame*, std::tuple<int, int>> GetObservations() const { return observations; }
  Eigen::Vector3f GetWorldPos() const { return P; }
  void SetWorldPos(const Eigen::Vector3f& p) { P = p; }
  void UpdateNormalAndDepth() { ++updates; }
  void EraseObservation(KeyFrame* kf) { observations.erase(kf); }
  bool isBad() const { return false; }
  Map* GetMap() const { return map; }
};

struct Map : rvwo::test::MapOf<KeyFrame, MapPoint> {};

rvwo::SE2 robotOfPose(const Pose& p, const Eigen::Isometry3d& T_b_c, double* off_plane) {
  return rvwo::test::robotOf(rvwo::orbslam3::isometryOf(p), T_b_c, off_plane);
}

// A drive that turns across theta = +-pi.
rvwo::SE2 drive(double t) { return rvwo::SE2(0.6 * t, 0.15 * t * t, M_PI - 0.2 + 0.5 * t); }

// Twelve keyframes 0.1 s apart along the drive, the newest (11) covisible with 4 to 10: those
// are free, 0 to 3 (which see the same points) fixed. Points seen with 1 px noise at level 0,
// one observation in 20 is 30 px off; keyframe `blind` sees nothing (placed by the wheels alone).
struct Scene {
  static constexpr int kKeyFrames = 12, kPoints = 300, kBlind = 8;
  Eigen::Isometry3d T_b_c = tiltedCamera();
  Map map;
  std::vector<std::unique_ptr<KeyFrame>> kfs;
  std::vector<std::unique_ptr<MapPoint>> mps;
  std::vector<Eigen::Vector3d> truth_P;  // in ORB-SLAM3's world
  std::map<std::pair<KeyFrame*, MapPoint*>, bool> bad;
  WheelInput wheels;

  // turn_error: the wheels claim every turn this much (relative) too large, as a wrong track does.
  // step_scale: the calibration's step (or drift) times this; constant: counted, with the drift
  // (else a walk of the step).
  explicit Scene(unsigned seed, bool local_map = true, double turn_error = 0.0, bool calibrate = true,
                 double step_scale = 1.0, bool constant = false, bool calibrate_distance = true) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), depth(1.5, 6.0), coin(0, 1);
    std::normal_distribution<double> g(0, 1);
    WheelInputParams p;
    p.T_b_c = T_b_c;
    p.local_map = local_map;
    p.calibrate = calibrate;
    p.calibration_step *= step_scale;
    p.calibration_drift *= step_scale;
    p.calibration_constant = constant;
    p.calibrate_distance = calibrate_distance;
    wheels.configure(p);
    std::vector<WheelReading> readings;
    rvwo::SE2 x = drive(0);
    for (int k = 0; k <= 120; ++k) {
      if (k > 0) {
        Eigen::Vector3d xi = (drive(0.01 * (k - 1)).inverse() * drive(0.01 * k)).log();
        xi.z() *= 1.0 + turn_error;
        x = x * rvwo::SE2::exp(xi);
      }
      readings.push_back(WheelReading::pose(0.01 * k, x.translation().x(), x.translation().y(), x.angle()));
    }
    wheels.add(readings);
    for (int k = 0; k < kKeyFrames; ++k) {
      kfs.push_back(std::make_unique<KeyFrame>());
      KeyFrame& kf = *kfs.back();
      kf.mnId = static_cast<unsigned long>(k);
      kf.mTimeStamp = 0.1 * k;
      kf.map = &map;
      kf.pose = rvwo::orbslam3::poseOf<Pose>(cameraPose(drive(kf.mTimeStamp), T_b_c));
      map.keyframes.push_back(&kf);
    }
    for (int k = 4; k < kKeyFrames - 1; ++k) kfs.back()->covisible.push_back(kfs[k].get());
    for (int i = 0; i < kPoints; ++i) {
      // In view of a keyframe of the middle, then seen by every keyframe it projects into.
      const Eigen::Isometry3d T_w_c = rvwo::orbslam3::isometryOf(kfs[3 + i % 6]->pose).inverse();
      const double z = depth(rng);
      const Eigen::Vector2d uv = rvwo::test::drawVector<2>(u, rng);
      truth_P.push_back(T_w_c * Eigen::Vector3d(uv.x() * 0.6 * z, uv.y() * 0.45 * z, z));
      mps.push_back(std::make_unique<MapPoint>());
      MapPoint& mp = *mps.back();
      mp.mnId = static_cast<unsigned long>(1000 + i);
      mp.map = &map;
      mp.P = truth_P.back().cast<float>();
      map.points.push_back(&mp);
      for (int k = 0; k < kKeyFrames; ++k) {
        KeyFrame& kf = *kfs[k];
        if (k == kBlind) continue;
        const Eigen::Vector3d P_c = rvwo::orbslam3::isometryOf(kf.pose) * truth_P.back();
        const double px = kf.fx * P_c.x() / P_c.z() + kf.cx, py = kf.fy * P_c.y() / P_c.z() + kf.cy;
        if (P_c.z() < 0.5 || px < 0 || px > 640 || py < 0 || py > 480) continue;
        cv::KeyPoint kp;
        kp.octave = i % 3;
        const double s = std::pow(1.2, kp.octave);
        const bool off = coin(rng) < 0.05;
        const double du = off ? (coin(rng) < 0.5 ? -30 : 30) : 0, dv = off ? 30 * u(rng) : 0;
        kp.pt.x = static_cast<float>(px + s * g(rng) + du);
        kp.pt.y = static_cast<float>(py + s * g(rng) + dv);
        const int index = static_cast<int>(kf.mvKeysUn.size());
        kf.mvKeysUn.push_back(kp);
        kf.mvuRight.push_back(kp.pt.x - static_cast<float>(kf.mbf / P_c.z()));
        kf.matches.push_back(&mp);
        mp.observations[&kf] = std::make_tuple(index, -1);
        bad[{&kf, &mp}] = off;
      }
    }
  }
  // ORB-SLAM3 marks what a keyframe's local map took (mnBALocalForKF and mnBAFixedForKF, the
  // keyframe's id): cleared, the same local map is solved again.
  void again() {
    for (auto& kf : kfs) kf->mnBALocalForKF = kf->mnBAFixedForKF = 1000;
    for (auto& mp : mps) mp->mnBALocalForKF = 1000;
  }
  // Local keyframes 5 cm, 3 deg off and out of the plane; points 3 cm off.
  void perturb(unsigned seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0, 1);
    for (int k = 4; k < kKeyFrames; ++k) {
      const Eigen::Vector3d n = Eigen::Vector3d(0.04, 0.03, 0.05).cwiseProduct(rvwo::test::drawVector<3>(g, rng));
      Eigen::Isometry3d T = cameraPose(drive(0.1 * k) * rvwo::SE2::fromVector(n), T_b_c);
      T.translation() += Eigen::Vector3d(0.0, 0.02, 0.0);  // camera y: down, off the plane
      kfs[k]->pose = rvwo::orbslam3::poseOf<Pose>(T);
    }
    for (auto& mp : mps) mp->P += (static_cast<double>(0.03f) * rvwo::test::drawVector<3>(g, rng)).cast<float>();
  }
};

TEST(WheelInputLocalMap, RecoversTheDriveOnThePlaneAndErasesWhatIsOff) {
  Scene scene(1);
  scene.perturb(2);
  const std::vector<Pose> fixed_before = {scene.kfs[0]->pose, scene.kfs[1]->pose, scene.kfs[2]->pose,
                                          scene.kfs[3]->pose};
  bool stop = false;
  ASSERT_TRUE(rvwo::orbslam3::optimiseLocalMap(scene.wheels, scene.kfs.back().get(), &stop, &scene.map));
  EXPECT_EQ(scene.map.changes, 1);
  // Fixed keyframes untouched, free ones on the plane where the drive was.
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ((scene.kfs[k]->pose.R - fixed_before[k].R).norm(), 0.0f) << k;
    EXPECT_EQ((scene.kfs[k]->pose.t - fixed_before[k].t).norm(), 0.0f) << k;
  }
  for (int k = 4; k < Scene::kKeyFrames; ++k) {
    double off_plane = 1;
    const rvwo::SE2 e = drive(0.1 * k).inverse() * robotOfPose(scene.kfs[k]->pose, scene.T_b_c, &off_plane);
    // From 4 cm and 50 mrad off. The outliers' pull under the kernel leaves 5 to 7 mm and 1.1 to
    // 1.8 mrad (4.5 mm and 0.9 mrad without them). The blind keyframe: its wheel edges alone.
    EXPECT_LT(e.translation().norm(), 0.01) << k;
    EXPECT_LT(std::fabs(e.angle()), 2.5e-3) << k;
    EXPECT_LT(off_plane, 1e-5) << k;
  }
  // Every point written back (and its normal updated). Stereo depth from one view is good to
  // z^2 / bf px (0.5 m at 5 m here) and the keyframes see them from nearly one line: a point may
  // move along its ray, not across it.
  const Eigen::Isometry3d T_c_w = rvwo::orbslam3::isometryOf(scene.kfs.back()->pose);
  double worst_across = 0, worst_along = 0;
  for (std::size_t i = 0; i < scene.mps.size(); ++i) {
    EXPECT_EQ(scene.mps[i]->updates, 1);
    const Eigen::Vector3d P_c = T_c_w * scene.mps[i]->P.cast<double>(), truth_c = T_c_w * scene.truth_P[i];
    const Eigen::Vector3d ray = truth_c.normalized(), e = P_c - truth_c;
    const double z2 = truth_c.squaredNorm();
    worst_along = std::max(worst_along, std::fabs(e.dot(ray)) / z2);
    worst_across = std::max(worst_across, (e - e.dot(ray) * ray).norm() / std::sqrt(z2));
  }
  EXPECT_LT(worst_along, 0.05);    // 30 px off observations pull too (0.014 without them)
  EXPECT_LT(worst_across, 0.015);  // rad (0.004 without them)
  // Observations 30 px off erased from both sides; nearly all others kept.
  int off = 0, off_erased = 0, good = 0, good_kept = 0;
  for (const auto& [pair, is_off] : scene.bad) {
    const bool kept = pair.second->observations.count(pair.first) > 0;
    const bool matched =
        std::find(pair.first->matches.begin(), pair.first->matches.end(), pair.second) != pair.first->matches.end();
    EXPECT_EQ(kept, matched);
    off += is_off;
    off_erased += is_off && !kept;
    good += !is_off;
    good_kept += !is_off && kept;
  }
  ASSERT_GT(off, 50);
  EXPECT_EQ(off_erased, off);
  EXPECT_GT(good_kept, 0.97 * good);
}

TEST(WheelInputLocalMap, WithoutTheWheelsTheBlindKeyframeStaysWhereItWas) {
  // The same scene, the blind keyframe stamped where the readings do not reach (they end at
  // 1.2 s): no wheel edge reaches it, so it is not in the problem and keeps its start, out of the
  // plane as it is (the check above is the wheel edges' doing).
  Scene scene(1);
  scene.perturb(2);
  scene.kfs[Scene::kBlind]->mTimeStamp = 5.0;
  const Pose before = scene.kfs[Scene::kBlind]->pose;
  bool stop = false;
  ASSERT_TRUE(rvwo::orbslam3::optimiseLocalMap(scene.wheels, scene.kfs.back().get(), &stop, &scene.map));
  EXPECT_EQ((scene.kfs[Scene::kBlind]->pose.t - before.t).norm(), 0.0f);
  double off_plane = 1;
  robotOfPose(scene.kfs[7]->pose, scene.T_b_c, &off_plane);
  EXPECT_LT(off_plane, 1e-5);  // its neighbours solved
}

// The turn over the whole drive as the wheels (with the calibration learnt so far) tell it, less
// the truth's.
double turnError(const Scene& scene) {
  const Eigen::Isometry3d T_c0_w = cameraPose(drive(0), scene.T_b_c), T_c1_w = cameraPose(drive(1.1), scene.T_b_c);
  const Eigen::Isometry3d predicted = scene.wheels.predict(T_c0_w, 0.0, 1.1);
  return Eigen::AngleAxisd((predicted * T_c1_w.inverse()).linear()).angle();
}

// Local maps on the same keyframes, again and again (`rounds` of them).
void localMapsAgain(Scene* scene, int rounds) {
  for (int round = 0; round < rounds; ++round) {
    scene->again();
    bool stop = false;
    ASSERT_TRUE(rvwo::orbslam3::optimiseLocalMap(scene->wheels, scene->kfs.back().get(), &stop, &scene->map));
  }
}

TEST(WheelInputLocalMap, LearnsTheWheelsCalibrationWhereTheyAgree) {
  // Wheels claiming 4 % too much turn (0.5 rad over the drive: 20 mrad off). As a walk (the
  // default), each local map moves the calibration at most about a step (its prior around the
  // last), a random walk in time: the same keyframes again have a tenth of it
  // (wheelCalibrationStep). With the default step (0.003 in turn scale), 40 local maps at one
  // time hardly move it...
  Scene once(1, true, 0.04);
  const double before = turnError(once);
  EXPECT_GT(before, 0.015);
  once.perturb(10);
  localMapsAgain(&once, 40);
  EXPECT_GT(turnError(once), 0.9 * before) << once.wheels.calibration().transpose();
  // ... and with ten times the step, each as far as a local map half a second after the last.
  Scene walk(1, true, 0.04, true, 10.0);
  walk.perturb(10);
  localMapsAgain(&walk, 40);
  EXPECT_LT(turnError(walk), 0.25 * before) << walk.wheels.calibration().transpose();
  // A constant, counted (Odometry.CalibrationConstant 1), has only the prior around zero in its
  // first local map, and learns it there; the same keyframes again add nothing new.
  Scene first(1, true, 0.04, true, 1.0, true);
  first.perturb(10);
  localMapsAgain(&first, 1);
  EXPECT_LT(turnError(first), 0.25 * before) << first.wheels.calibration().transpose();
  Scene scene(1, true, 0.04, true, 1.0, true);
  scene.perturb(10);
  localMapsAgain(&scene, 40);
  EXPECT_LT(turnError(scene), 0.25 * before) << scene.wheels.calibration().transpose();
  // Odometry.CalibrateDistance 0 (mono's default): the distance scale stays nominal, the rest is learnt.
  Scene held(1, true, 0.04, true, 10.0, false, false);
  held.perturb(10);
  localMapsAgain(&held, 40);
  EXPECT_EQ(held.wheels.calibration().x(), 0.0);
  EXPECT_LT(turnError(held), 0.25 * before) << held.wheels.calibration().transpose();
  // Counted, the first local map has the prior around zero alone: what its bounds (3 sigma) cannot
  // explain, three times the turn, is left alone.
  Scene way_off(1, true, 2.0, true, 1.0, true);
  way_off.perturb(10);
  localMapsAgain(&way_off, 3);
  EXPECT_EQ(way_off.wheels.localMapsSolved(), 3u);
  EXPECT_EQ(way_off.wheels.localMapsCalibrated(), 0u);
  EXPECT_EQ(way_off.wheels.calibration().norm(), 0.0);
  // Each of them solved, and each refined the calibration: they agree with the wheels once it is applied.
  EXPECT_EQ(scene.wheels.localMapsSolved(), 40u);
  EXPECT_EQ(scene.wheels.localMapsCalibrated(), 40u);
  // The poses stay where the drive was: vision holds them, the calibration absorbs the wheels'.
  for (int k = 4; k < Scene::kKeyFrames; ++k) {
    double off_plane = 1;
    const rvwo::SE2 e = drive(0.1 * k).inverse() * robotOfPose(scene.kfs[k]->pose, scene.T_b_c, &off_plane);
    EXPECT_LT(e.translation().norm(), 0.01) << k;
    EXPECT_LT(std::fabs(e.angle()), 2.5e-3) << k;
  }
  // Odometry.Calibrate 0: the turn stays as the wheels tell it.
  Scene fixed(1, true, 0.04, false, 10.0);
  fixed.perturb(10);
  localMapsAgain(&fixed, 15);
  EXPECT_EQ(fixed.wheels.calibration().norm(), 0.0);
  EXPECT_EQ(fixed.wheels.localMapsSolved(), 15u);
  EXPECT_EQ(fixed.wheels.localMapsCalibrated(), 0u);
  EXPECT_NEAR(turnError(fixed), before, 1e-9);
  // Wheels 50 % off in turn, far beyond what a step explains: solved, the calibration left alone.
  Scene off(1, true, 0.5);
  off.perturb(10);
  localMapsAgain(&off, 3);
  EXPECT_EQ(off.wheels.localMapsSolved(), 3u);
  EXPECT_EQ(off.wheels.localMapsCalibrated(), 0u);
  EXPECT_EQ(off.wheels.calibration().norm(), 0.0);
}

TEST(WheelInputGlobalMap, AfterALoopTheWholeMapGoesToTheGbaFieldsOrIntoTheMap) {
  for (const unsigned long loop_kf : {11ul, 0ul}) {  // a loop's keyframe; the map's origin
    Scene scene(6);
    scene.perturb(7);
    for (int k = 1; k < 4; ++k)  // the keyframes ORB-SLAM3's local map held fixed are free here
      scene.kfs[k]->pose =
          rvwo::orbslam3::poseOf<Pose>(cameraPose(drive(0.1 * k) * rvwo::SE2(0.03, 0.02, 0.03), scene.T_b_c));
    std::vector<Pose> before;
    for (const auto& kf : scene.kfs) before.push_back(kf->pose);
    const Eigen::Vector3f P_before = scene.mps[5]->P;
    bool stop = false;
    ASSERT_TRUE(rvwo::orbslam3::optimiseGlobalMap(scene.wheels, &scene.map, &stop, loop_kf));
    const bool into_map = loop_kf == 0;
    for (int k = 1; k < Scene::kKeyFrames; ++k) {
      const KeyFrame& kf = *scene.kfs[k];
      EXPECT_EQ(kf.mnBAGlobalForKF, into_map ? 0ul : loop_kf);
      // For a loop, the map stays as it was until the loop closer applies the result.
      if (!into_map) {
        EXPECT_EQ((kf.pose.t - before[k].t).norm(), 0.0f) << k;
      }
      double off_plane = 1;
      const rvwo::SE2 e =
          drive(0.1 * k).inverse() * robotOfPose(into_map ? kf.pose : kf.mTcwGBA, scene.T_b_c, &off_plane);
      EXPECT_LT(e.translation().norm(), 0.01) << k;
      EXPECT_LT(std::fabs(e.angle()), 2.5e-3) << k;
      EXPECT_LT(off_plane, 1e-5) << k;
    }
    EXPECT_EQ(scene.mps[5]->mnBAGlobalForKF, into_map ? 0ul : loop_kf);
    EXPECT_EQ(scene.mps[5]->P == P_before, !into_map);
    EXPECT_EQ(scene.map.changes, 0);  // nothing erased
  }
}

TEST(WheelInputGlobalMap, AKeyframeNothingPlacesFollowsItsParent) {
  // The blind keyframe stamped beyond the readings (made on the wheels in a blackout, older than
  // the readings kept): nothing in the problem places it. Left unmarked, the loop closer moves it
  // with its parent in the spanning tree; marked, it would keep its old pose as its neighbours
  // moved. The fixed origin is marked: the loop closer applies every origin's result.
  Scene scene(6);
  scene.perturb(7);
  scene.kfs[Scene::kBlind]->mTimeStamp = 5.0;
  bool stop = false;
  ASSERT_TRUE(rvwo::orbslam3::optimiseGlobalMap(scene.wheels, &scene.map, &stop, 11));
  for (int k = 0; k < Scene::kKeyFrames; ++k)
    EXPECT_EQ(scene.kfs[k]->mnBAGlobalForKF, k == Scene::kBlind ? 0ul : 11ul) << k;
}

TEST(WheelInputGlobalMap, KeyframesKeepTheirWheelsForTheWholeMap) {
  // 60 s on a gentle S (0.5 m/s), readings at 100 Hz as tracking gives them (it keeps the last
  // 20 s), a keyframe a second, each first seen in its local map; one (30.5 s) first seen only
  // after the next one's. After a loop at 60 s the global problem, every keyframe but the first
  // free and 0.4 m off, has a wheel edge between each pair consecutive in time: the chain of
  // keyframes outlives the readings. Wheel edges alone then put every keyframe on the drive.
  const Eigen::Isometry3d T_b_c = tiltedCamera();
  WheelInputParams p;
  p.T_b_c = T_b_c;
  p.calibrate = false;
  WheelInput wheels;
  wheels.configure(p);
  const auto truth = [](double t) {
    return rvwo::SE2(0.5 * t, 1.5 * std::sin(0.1 * t), std::atan(0.3 * std::cos(0.1 * t)));
  };
  const auto problem = [&](const std::vector<double>& t, int fixed, double off) {
    rvwo::orbslam3::LocalMapProblem pb;
    pb.scale_factor = 1.2;
    for (std::size_t k = 0; k < t.size(); ++k)
      pb.keyframes.push_back({k, t[k], cameraPose(truth(t[k]) * (k ? rvwo::SE2(off, -off, 0) : rvwo::SE2()), T_b_c),
                              static_cast<int>(k) < fixed, 400, 400, 319.5, 239.5, 48});
    return pb;
  };
  rvwo::orbslam3::LocalMapSolution solution;
  for (int i = 0; i <= 6000; ++i) {
    const double t = 0.01 * i;
    const rvwo::SE2 x = truth(t);
    wheels.add({WheelReading::pose(t, x.translation().x(), x.translation().y(), x.angle())});
    if (i % 10) continue;
    wheels.frameTracked(t, true, 1000);
    if (i % 100 || i == 0) continue;
    const double s = std::round(t);
    ASSERT_TRUE(wheels.optimiseLocalMap(problem({s - 1, s}, 1, 0), &solution));
    EXPECT_EQ(solution.wheel_edges, 1) << t;
    if (s == 32) {  // 30.5 s first seen now, between 30 and 31 (both seen before)
      ASSERT_TRUE(wheels.optimiseLocalMap(problem({30, 30.5, 31}, 1, 0), &solution));
      EXPECT_EQ(solution.wheel_edges, 2);
    }
  }
  ASSERT_FALSE(wheels.covers(30, 41));  // the readings kept: from 40 s on
  std::vector<double> t;
  for (int k = 0; k <= 60; ++k) {
    t.push_back(k);
    if (k == 30) t.push_back(30.5);
  }
  const rvwo::orbslam3::LocalMapProblem global = problem(t, 1, 0.3);
  ASSERT_TRUE(wheels.optimiseLocalMap(global, &solution));
  EXPECT_EQ(solution.wheel_edges, static_cast<int>(t.size()) - 1);
  for (std::size_t k = 1; k < t.size(); ++k) {
    EXPECT_TRUE(solution.placed[k]) << t[k];
    double off_plane = 1;
    const rvwo::SE2 e = truth(t[k]).inverse() * rvwo::test::robotOf(solution.T_c_w[k], T_b_c, &off_plane);
    EXPECT_LT(e.translation().norm(), 1e-4) << t[k];
    EXPECT_LT(std::fabs(e.angle()), 1e-5) << t[k];
  }
  // A keyframe never seen while the readings covered it has no wheel edge, to or from it.
  t.push_back(10.25);
  std::sort(t.begin(), t.end());
  ASSERT_TRUE(wheels.optimiseLocalMap(problem(t, 1, 0.3), &solution));
  EXPECT_EQ(solution.wheel_edges, static_cast<int>(t.size()) - 1 - 2);
}

TEST(WheelInputLocalMap, ConcurrentWithTracking) {
  // ORB-SLAM3's local mapping thread solves local maps while tracking adds readings, predicts and
  // reports frames (run under ThreadSanitizer by scripts/test.sh).
  Scene scene(8);
  scene.perturb(9);
  std::thread tracking([&] {
    rvwo::SE2 x = drive(1.2);
    for (int k = 1; k <= 300; ++k) {
      const double t = 1.2 + 0.01 * k;
      x = x * rvwo::SE2(0.006, 0.0, 0.005);
      scene.wheels.add({WheelReading::pose(t, x.translation().x(), x.translation().y(), x.angle())});
      const Eigen::Isometry3d T = scene.wheels.predict(Eigen::Isometry3d::Identity(), t - 0.01, t);
      EXPECT_TRUE(T.matrix().allFinite());
      if (k % 3 == 0) scene.wheels.frameTracked(t, true, 800);
      EXPECT_EQ(scene.wheels.alpha(1000), 1.0);
      EXPECT_TRUE(scene.wheels.calibration().allFinite());
    }
  });
  for (int round = 0; round < 4; ++round) {
    scene.again();
    bool stop = false;
    EXPECT_TRUE(rvwo::orbslam3::optimiseLocalMap(scene.wheels, scene.kfs.back().get(), &stop, &scene.map));
  }
  tracking.join();
  for (int k = 4; k < Scene::kKeyFrames; ++k) {
    double off_plane = 1;
    const rvwo::SE2 e = drive(0.1 * k).inverse() * robotOfPose(scene.kfs[k]->pose, scene.T_b_c, &off_plane);
    EXPECT_LT(e.translation().norm(), 0.01) << k;
  }
}

TEST(WheelInputLocalMap, StopFlagOrLocalMappingOffLeaveTheMapAlone) {
  for (const bool local_map : {true, false}) {
    Scene scene(3, local_map);
    scene.perturb(4);
    const Pose before = scene.kfs[6]->pose;
    const Eigen::Vector3f P_before = scene.mps[10]->P;
    bool stop = local_map;  // ORB-SLAM3 asked local mapping to stop before the solve
    EXPECT_EQ(rvwo::orbslam3::optimiseLocalMap(scene.wheels, scene.kfs.back().get(), &stop, &scene.map), local_map);
    EXPECT_EQ((scene.kfs[6]->pose.t - before.t).norm(), 0.0f);
    EXPECT_EQ((scene.mps[10]->P - P_before).norm(), 0.0f);
    EXPECT_EQ(scene.map.changes, 0);
    EXPECT_EQ(scene.wheels.localMapsSolved(), 0u);
  }
}

TEST(WheelInputLocalMap, MonocularLeavesItToOrbSlam3) {
  Scene scene(5);
  WheelInputParams p;
  p.T_b_c = scene.T_b_c;
  p.map_from_depth = false;  // Sensor: mono
  scene.wheels.configure(p);
  bool stop = false;
  EXPECT_FALSE(scene.wheels.optimisesLocalMaps());
  EXPECT_FALSE(rvwo::orbslam3::optimiseLocalMap(scene.wheels, scene.kfs.back().get(), &stop, &scene.map));
  EXPECT_FALSE(rvwo::orbslam3::optimiseGlobalMap(scene.wheels, &scene.map, &stop, 11));
}

// ---- vision back after a blackout: the old map found from the wheels' pose (reacquire.h)

constexpr double kBf = 48;  // the stand-in frames' stereo baseline times fx [px m]

// As ORB-SLAM3's Frame, with the members optimisePose and reacquire use. A feature's descriptor
// is the id of the point it shows (0: none of the map's).
struct Frame {
  inline static float fx = 400, fy = 400, cx = 319.5f, cy = 239.5f;
  double mTimeStamp = 0;
  float mbf = static_cast<float>(kBf), mfScaleFactor = 1.2f;
  const void* mpCamera2 = nullptr;
  rvwo::test::Camera* mpCamera = rvwo::test::pinholeCamera();
  int N = 0;
  std::vector<cv::KeyPoint> mvKeysUn;
  std::vector<float> mvuRight;
  std::vector<MapPoint*> mvpMapPoints;
  std::vector<bool> mvbOutlier;
  std::vector<unsigned long> descriptor;
  std::vector<char> misplaced;  // 8 to 12 px off its point along the row: a wrong match the window lets in
  Pose pose;
  bool has_pose = false;
  Pose GetPose() const { return pose; }
  void SetPose(const Pose& p) {
    pose = p;
    has_pose = true;
  }
  bool HasPose() const { return has_pose; }
};

// Where the stand-in frames' camera sees P_c (in its frame).
Eigen::Vector2d pixelOf(const Eigen::Vector3d& P_c) {
  return {Frame::fx * P_c.x() / P_c.z() + Frame::cx, Frame::fy * P_c.y() / P_c.z() + Frame::cy};
}

// As ORBmatcher::SearchByProjection(Frame&, KeyFrame*, found, th, ORBdist), relocalisation's:
// each of the keyframe's points not found yet, projected from the frame's pose, takes the first
// free feature with its descriptor within th px (times its level's scale).
struct Matcher {
  Matcher(float, bool) {}
  int SearchByProjection(Frame& f, KeyFrame* kf, const std::set<MapPoint*>& found, float th, int) const {
    const Eigen::Isometry3d T_c_w = rvwo::orbslam3::isometryOf(f.GetPose());
    int n = 0;
    for (MapPoint* mp : kf->matches) {
      if (!mp || found.count(mp)) continue;
      const Eigen::Vector3d P_c = T_c_w * mp->P.cast<double>();
      if (P_c.z() < 0.1) continue;
      const Eigen::Vector2d uv = pixelOf(P_c);
      for (int i = 0; i < f.N; ++i) {
        if (f.mvpMapPoints[i] || f.descriptor[i] != mp->mnId) continue;
        if (std::hypot(f.mvKeysUn[i].pt.x - uv.x(), f.mvKeysUn[i].pt.y - uv.y()) >
            th * std::pow(1.2, f.mvKeysUn[i].octave))
          continue;
        f.mvpMapPoints[i] = mp;
        ++n;
        break;
      }
    }
    return n;
  }
};

// A turning drive; the wheels claim 2 % more distance and 1.5 deg more turn over 4 s.
rvwo::SE2 curve(double t) { return rvwo::SE2(0.3 * t, 0.03 * t * t, 0.1 * t); }
rvwo::SE2 curveClaimed(double t) {
  const rvwo::SE2 x = curve(t);
  return rvwo::SE2(1.02 * x.translation().x(), 1.02 * x.translation().y(), x.angle() + 0.0065 * t);
}

// Vision last placed a frame at 0 s (keyframe `reference`, with a covisible one from -0.3 s);
// the lens was covered until 4 s, the wheels carried the frames. 400 points 3 to 7 m ahead.
struct Blackout {
  Eigen::Isometry3d T_b_c = tiltedCamera();
  WheelInput wheels;
  KeyFrame reference, covisible;
  std::vector<std::unique_ptr<MapPoint>> mps;
  Frame last, frame;
  Eigen::Isometry3d T_c_w_wheels;  // where the wheels put the frame at 4 s

  Blackout() {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> x(3, 7), y(-2.5, 3.5), z(0.1, 1.5), coin(0, 1), off(8, 12);
    std::normal_distribution<double> g(0, 0.5);
    WheelInputParams p;
    p.T_b_c = T_b_c;
    wheels.configure(p);
    std::vector<WheelReading> readings;
    for (int k = -40; k <= 420; ++k) {
      const rvwo::SE2 c = curveClaimed(0.01 * k);
      readings.push_back(WheelReading::pose(0.01 * k, c.translation().x(), c.translation().y(), c.angle()));
    }
    wheels.add(readings);
    reference.pose = rvwo::orbslam3::poseOf<Pose>(cameraPose(curve(0), T_b_c));
    covisible.pose = rvwo::orbslam3::poseOf<Pose>(cameraPose(curve(-0.3), T_b_c));
    covisible.mTimeStamp = -0.3;
    reference.covisible = {&covisible};
    const Eigen::Isometry3d T_c4_w = cameraPose(curve(4.0), T_b_c);
    frame.mTimeStamp = 4.0;
    for (int i = 0; i < 400; ++i) {
      mps.push_back(std::make_unique<MapPoint>());
      MapPoint& mp = *mps.back();
      mp.mnId = static_cast<unsigned long>(1 + i);
      const double pz = z(rng), py = y(rng), px = x(rng);                    // drawn as gcc did (tests/common/draw.h)
      mp.P = (T_b_c.inverse() * Eigen::Vector3d(px, py, pz)).cast<float>();  // ORB-SLAM3's world
      KeyFrame& kf = i % 2 ? covisible : reference;
      if (!project(rvwo::orbslam3::isometryOf(kf.pose), mp.P.cast<double>())) continue;
      kf.matches.push_back(&mp);
      const std::optional<Eigen::Vector3d> P_c = project(T_c4_w, mp.P.cast<double>());
      if (!P_c) continue;
      cv::KeyPoint kp;
      kp.octave = i % 3;
      const double s = std::pow(1.2, kp.octave);
      const Eigen::Vector2d uv = pixelOf(*P_c);
      const bool misplaced = coin(rng) < 0.05;
      // Along the row: the out-of-plane noise (eq. 10) widens the vertical error by the
      // robot's pitch, so that a wrong match 10 px up or down can pass the gate.
      const double d = misplaced ? (coin(rng) < 0.5 ? -off(rng) : off(rng)) : 0.0;
      kp.pt.x = static_cast<float>(uv.x() + s * g(rng) + d);
      kp.pt.y = static_cast<float>(uv.y() + s * g(rng));
      frame.mvKeysUn.push_back(kp);
      frame.mvuRight.push_back(kp.pt.x - static_cast<float>(kBf / P_c->z()));
      frame.descriptor.push_back(mp.mnId);
      frame.misplaced.push_back(misplaced);
    }
    for (int i = 0; i < 50; ++i) {  // features of nothing in the map
      cv::KeyPoint kp;
      const double cy = coin(rng), cx = coin(rng);  // drawn as gcc did (tests/common/draw.h)
      kp.pt = cv::Point2f(static_cast<float>(640 * cx), static_cast<float>(480 * cy));
      frame.mvKeysUn.push_back(kp);
      frame.mvuRight.push_back(-1);
      frame.descriptor.push_back(0);
      frame.misplaced.push_back(0);
    }
    frame.N = static_cast<int>(frame.mvKeysUn.size());
    frame.mvpMapPoints.assign(frame.N, nullptr);
    frame.mvbOutlier.assign(frame.N, false);

    // The last frame vision placed (0 s, the reference keyframe's view), then 39 on the wheels.
    Frame first;
    first.SetPose(reference.pose);
    for (MapPoint* mp : reference.matches) {
      const Eigen::Vector3d P_c = *project(rvwo::orbslam3::isometryOf(reference.pose), mp->P.cast<double>());
      cv::KeyPoint kp;
      const Eigen::Vector2d uv = pixelOf(P_c);
      kp.pt = cv::Point2f(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
      first.mvKeysUn.push_back(kp);
      first.mvuRight.push_back(kp.pt.x - static_cast<float>(kBf / P_c.z()));
      first.mvpMapPoints.push_back(mp);
    }
    first.N = static_cast<int>(first.mvKeysUn.size());
    first.mvbOutlier.assign(first.N, false);
    EXPECT_GE(rvwo::orbslam3::optimisePose(wheels, first, Frame(), upstream), 100);
    wheels.frameTracked(0.0, true, first.N);
    for (int k = 1; k < 40; ++k) wheels.frameTracked(0.1 * k, false, 0);
    last.mTimeStamp = 3.9;
    last.SetPose(rvwo::orbslam3::poseOf<Pose>(wheels.predict(rvwo::orbslam3::isometryOf(first.pose), 0.0, 3.9)));
    T_c_w_wheels = wheels.predict(rvwo::orbslam3::isometryOf(last.pose), 3.9, 4.0);
  }

  // P_c when the camera T_c_w sees P_w (in the image, 0.5 m or more ahead).
  static std::optional<Eigen::Vector3d> project(const Eigen::Isometry3d& T_c_w, const Eigen::Vector3d& P_w) {
    const Eigen::Vector3d P_c = T_c_w * P_w;
    if (P_c.z() < 0.5) return std::nullopt;
    const Eigen::Vector2d uv = pixelOf(P_c);
    if (uv.x() < 0 || uv.x() > 640 || uv.y() < 0 || uv.y() > 480) return std::nullopt;
    return P_c;
  }
  static int upstream(Frame*) {
    ADD_FAILURE() << "ORB-SLAM3's 6-DoF pose optimisation called for a stereo frame";
    return 0;
  }
  bool reacquire(const rvwo::orbslam3::ReacquireParams& params = {}) {
    return rvwo::orbslam3::reacquire<Matcher>(
        frame, &reference, rvwo::orbslam3::poseOf<Pose>(T_c_w_wheels),
        [this] { return rvwo::orbslam3::optimisePose(wheels, frame, last, upstream); }, params);
  }
  int matched() const {
    return static_cast<int>(
        std::count_if(frame.mvpMapPoints.begin(), frame.mvpMapPoints.end(), [](MapPoint* mp) { return mp; }));
  }
};

// A single fisheye camera (KannalaBrandt8) keeps its keypoints distorted, which the plugin's
// pinhole solve cannot read: ORB-SLAM3's own optimisation places such a frame.
TEST(OptimisePose, LeavesAFisheyeFrameToOrbSlam3) {
  rvwo::orbslam3::WheelInput wheels;
  wheels.configure(rvwo::orbslam3::WheelInputParams());
  ASSERT_TRUE(wheels.optimisesPoses());
  static int calls = 0;
  auto upstream = [](Frame*) { return ++calls, 77; };
  // Five matches in front of it: enough for the plugin to answer, were the camera a pinhole.
  std::vector<MapPoint> points(5);
  Frame frame, last;
  for (std::size_t k = 0; k < points.size(); ++k) {
    points[k].mnId = k;
    points[k].P = Eigen::Vector3f(0.3f * k - 0.6f, 0.1f * k, 3.0f);
    cv::KeyPoint kp;
    kp.pt = cv::Point2f(300.f + 40.f * k, 250.f);
    frame.mvKeysUn.push_back(kp);
    frame.mvuRight.push_back(kp.pt.x - 16.f);
    frame.mvpMapPoints.push_back(&points[k]);
  }
  frame.N = 5;
  frame.mvbOutlier.assign(5, false);
  frame.mpCamera = rvwo::test::fisheyeCamera();
  EXPECT_EQ(rvwo::orbslam3::optimisePose(wheels, frame, last, +upstream), 77);
  EXPECT_EQ(calls, 1);
  frame.mpCamera = rvwo::test::pinholeCamera();  // the same frame from a pinhole: the plugin's
  EXPECT_NE(rvwo::orbslam3::optimisePose(wheels, frame, last, +upstream), 77);
  EXPECT_EQ(calls, 1);
}

TEST(Reacquire, FindsTheOldMapFromTheWheelsPoseAndDropsWrongMatches) {
  Blackout b;
  double off_plane = 1;
  const rvwo::SE2 truth = curve(4.0);
  const rvwo::SE2 wheels = rvwo::test::robotOf(b.T_c_w_wheels, b.T_b_c, &off_plane);
  // The premise: the wheels' drift is far beyond what tracking searches (1 to 3 px).
  ASSERT_GT((wheels.translation() - truth.translation()).norm(), 0.02);
  ASSERT_GT(std::fabs(rvwo::wrapAngle(wheels.angle() - truth.angle())), 0.02);

  ASSERT_TRUE(b.reacquire());
  const rvwo::SE2 x = robotOfPose(b.frame.pose, b.T_b_c, &off_plane);
  EXPECT_LT((x.translation() - truth.translation()).norm(), 0.005);
  EXPECT_LT(std::fabs(rvwo::wrapAngle(x.angle() - truth.angle())), 1e-3);
  EXPECT_LT(off_plane, 1e-5);
  int good = 0, good_matched = 0;
  for (int i = 0; i < b.frame.N; ++i) {
    EXPECT_FALSE(b.frame.mvbOutlier[i]);
    if (b.frame.misplaced[i]) {
      EXPECT_EQ(b.frame.mvpMapPoints[i], nullptr) << "a wrong match kept, feature " << i;
    }
    if (b.frame.misplaced[i] || !b.frame.descriptor[i]) continue;
    ++good;
    good_matched += b.frame.mvpMapPoints[i] != nullptr;
  }
  EXPECT_GT(good, 100);
  EXPECT_GE(good_matched, 0.9 * good);
}

TEST(Reacquire, WithoutEnoughMatchesTheFrameStaysOnTheWheelsWithWhatItHad) {
  for (const int attempt : {0, 1, 2}) {
    Blackout b;
    b.frame.mvpMapPoints[0] = b.mps[0].get();  // what failed tracking left
    rvwo::orbslam3::ReacquireParams params;
    if (attempt == 0) params.window = 2;          // tracking's window: the drift is beyond it
    if (attempt == 1) params.min_inliers = 1000;  // fewer inliers than asked for
    const bool found = attempt == 2 ? rvwo::orbslam3::reacquire<Matcher>(b.frame, static_cast<KeyFrame*>(nullptr),
                                                                         rvwo::orbslam3::poseOf<Pose>(b.T_c_w_wheels),
                                                                         [] { return 1000; })
                                    : b.reacquire(params);
    EXPECT_FALSE(found) << attempt;
    EXPECT_EQ(b.matched(), 1) << attempt;
    EXPECT_EQ(b.frame.mvpMapPoints[0], b.mps[0].get()) << attempt;
    EXPECT_TRUE(rvwo::orbslam3::isometryOf(b.frame.pose).isApprox(b.T_c_w_wheels, 1e-6)) << attempt;
  }
}

}  // namespace
