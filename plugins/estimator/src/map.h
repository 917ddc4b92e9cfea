// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The estimator's map: keyframes, their points and each point's reliability (eqs. 4-7), the frames'
// poses relative to their keyframes, and what tracking may trust. Tracking adds keyframes, local
// mapping refines, culls and retires them: everything here is under `mutex`. Private to the library.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "context.h"
#include "rvwo/kernels/reliability.h"

namespace rvwo::estimator {

struct KeyFrame {
  std::uint64_t id = 0;
  double t = 0;
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // T_w_b as (x, y, theta)
  Features f;
  std::vector<std::int64_t> point;  // per feature: map point id, -1 none
  // Landmarks matched here but rejected by the pose's chi2 gate: not observations for the
  // bundle adjustment, but the keyframe's labels still speak of them (feature, point).
  std::vector<std::pair<int, std::uint64_t>> label_only;
  cv::Mat image;  // kept until segmented
  bool segmented = false;
  int tracked = 0;  // points tracked when it was made
};

struct MapPoint {
  std::uint64_t id = 0;
  Eigen::Vector3d P = Eigen::Vector3d::Zero();  // world
  cv::Mat descriptor;                           // 1 x 32
  int level = 0;                                // pyramid level where it was made ...
  double distance = 1;                          // ... and its distance from the camera then (m)
  std::map<std::uint64_t, int> obs;             // keyframe id -> feature index
  int visible = 0, found = 0;                   // frames it was predicted in view / matched in
  std::uint64_t first_kf = 0;
};

// Frames' poses: relative to their reference keyframe, so that refining keyframes moves them.
struct FrameRecord {
  double t;
  std::uint64_t ref_kf;
  SE2 T_kf_b;
  bool visual;
  bool slip = false;  // vision alone placed it (the wheels slipped)
};

struct Match {
  std::uint64_t point;
  int feature;
};

// Mono and RGB-D: new points are triangulated between a keyframe and this many keyframes before it.
constexpr int kTriangulationNeighbours = 5;

struct Map {
  // labels_later: labels come from a thread of their own, so a keyframe's points wait for them.
  Map(const Context& ctx, bool labels_later);

  mutable std::mutex mutex;
  std::map<std::uint64_t, KeyFrame> keyframes;         // in memory, by id (= time order)
  std::unordered_map<std::uint64_t, MapPoint> points;  // seen by keyframes in memory
  std::map<std::uint64_t, SE2> final_pose;             // keyframes that left memory
  std::vector<FrameRecord> frames;
  std::uint64_t next_kf = 0, next_point = 0;
  ReliabilityManager reliability;
  Report counters;

  // T_w_b of a keyframe, in memory or retired (identity if unknown).
  SE2 kfPose(std::uint64_t id) const;
  // A frame's T_w_b.
  SE2 pose(const FrameRecord& r) const { return kfPose(r.ref_kf) * r.T_kf_b; }

  // The point's kernel alpha: the adaptive kernel's (eq. 7), Estimator.FixedAlpha, or 1 (Huber).
  double kernelAlpha(std::uint64_t point) const;

  // A landmark no label has called dynamic (P_s below Tracking.TrustedMaxPs), and, with labels
  // coming later, not one whose keyframe still waits for its labels: a keyframe's new points are
  // the closest features, often a walker's, and counted as trusted for the frame or two until its
  // labels came they placed frames and made vision flicker (threaded RGB-D dynamic: trusted
  // matches 176, 26, 164, 17 in consecutive frames).
  bool isTrusted(std::uint64_t point) const;
  std::vector<char> trustedOf(const std::vector<Match>& matches) const;

  // Makes a keyframe from the frame's features: tracked points (point_of) become its observations,
  // close untracked features with depth new points (at least 100 when there are; none where
  // no_new_point), mono's and RGB-D's also by triangulation. Returns the points made.
  int createKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                     const cv::Mat& image, int tracked = 0, const std::vector<char>& no_new_point = {});

  // Points found in fewer than a quarter of the frames that should have seen them, or seen by
  // one keyframe only two keyframes after their birth: gone (ORB-SLAM's culling). Takes the lock.
  void cullPoints();

  // Keyframes beyond Estimator.KeepKeyFrames leave memory: their poses are final, their points
  // forgotten when no keyframe in memory sees them. Takes the lock. Returns the time of the oldest
  // keyframe left.
  std::optional<double> dropOldKeyFrames();

 private:
  // A new map point seen by feature i of kf at P_w (world), distance m from its camera.
  MapPoint& newPoint(KeyFrame* kf, int i, const Eigen::Vector3d& P_w, double distance);

  // Mono and RGB-D (not stereo, decision 0020): new points from kf's untracked features matched
  // with those of the keyframes before it (kTriangulationNeighbours; two were too few to keep a
  // map through a slow turn) (ORB-SLAM's CreateNewMapPoints, with the keyframes' poses known).
  // Those poses carry the wheels' metric scale (the first two keyframes are placed by the wheels
  // alone), so the map has it too; a turn on the spot (a baseline under Estimator.MonoMinBaseline)
  // triangulates nothing, which is how a pure-rotation start is refused. A pair must lie on the
  // epipolar plane (within 3 sigma of the coarser level, plus 2 mrad for the poses; an
  // EpipolarIndex of the older keyframe's rays finds them without a scan of all pairs), match
  // (Hamming <= 50, best clearly before second), meet at a parallax >= Estimator.MonoMinParallax in
  // front of both cameras and reproject within the mono chi2 gate in both. None from a feature
  // where no_new_point (a walker's). Returns the points made.
  int triangulate(KeyFrame* kf, const std::vector<char>& no_new_point);

  void eraseObservations(const MapPoint& p);
  // A point leaves: counted if its kernel had rejected it, its reliability forgotten.
  void forget(std::uint64_t point);

  const Context& ctx_;
  const bool labels_later_;
};

}  // namespace rvwo::estimator
