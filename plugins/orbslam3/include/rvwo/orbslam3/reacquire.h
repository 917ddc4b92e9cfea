// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// Vision back after the wheels carried the frames (lens covered, no texture): find the map that
// vision left before starting a new one. ORB-SLAM3 tracks a frame from the last frame's matches
// or the reference keyframe's words. After a blackout the last frame has no matches and the view
// has moved, so both fail, and the frame became a keyframe at the wheels' pose: a new map, turned
// from the old one by the wheels' drift over the blackout and never turned back (stereo blackout
// suite: 1.1 deg between the maps before and after 20-24 s, the run's largest error).
//
// reacquire() projects the map points of the reference keyframe (the last one vision made) and
// of its covisible keyframes into the frame from its pose (the wheels'), searching a window wide
// enough for the wheels' drift, as ORB-SLAM3's relocalisation does around a candidate keyframe.
// With enough matches, `place` (the pose optimisation) places the frame and drops its outliers.
// Included by the patched Tracking.cc (C++11); templated on ORB-SLAM3's types and matcher.
#pragma once

#include <cstddef>
#include <set>
#include <type_traits>
#include <vector>

namespace rvwo {
namespace orbslam3 {

struct ReacquireParams {
  float window = 15.0f;    // search radius [px at pyramid level 0]: ORB-SLAM3's own after a loss
  int covisible = 10;      // keyframes searched beside the reference (its best covisible ones)
  int max_distance = 100;  // ORB descriptor distance of a match (ORBmatcher::TH_HIGH)
  int min_inliers = 30;    // TrackLocalMap's own minimum
};

// frame: an ORB-SLAM3 Frame vision could not place. reference: the keyframe vision last tracked
// against. from: where the wheels put the frame (T_c_w). MatcherT: ORBmatcher, built (nnratio
// 0.9, check orientation) as relocalisation builds it. place(): optimises the frame's pose from
// its matches and returns the inliers. True: the frame is placed on the old map, its outliers
// dropped. False: the frame is at `from`, with the matches it came with.
template <class MatcherT, class FrameT, class KeyFrameT, class PoseT, class Place>
bool reacquire(FrameT& frame, KeyFrameT* reference, const PoseT& from, Place place,
               const ReacquireParams& params = ReacquireParams()) {
  typedef typename std::remove_pointer<typename std::decay<decltype(frame.mvpMapPoints[0])>::type>::type MapPointT;
  // What failed tracking left is kept for a failure here: the next frame's motion model starts
  // from it, as it did before reacquire() was tried.
  const std::vector<MapPointT*> left = frame.mvpMapPoints;
  const std::vector<bool> left_outlier(frame.mvbOutlier.begin(), frame.mvbOutlier.end());
  const auto giveUp = [&]() {
    frame.mvpMapPoints = left;
    for (std::size_t i = 0; i < frame.mvbOutlier.size(); ++i) frame.mvbOutlier[i] = left_outlier[i];
    frame.SetPose(from);
    return false;
  };
  if (!reference || reference->isBad()) return giveUp();
  for (std::size_t i = 0; i < frame.mvpMapPoints.size(); ++i) {
    frame.mvpMapPoints[i] = static_cast<MapPointT*>(0);
    frame.mvbOutlier[i] = false;
  }
  frame.SetPose(from);
  std::vector<KeyFrameT*> keyframes = reference->GetBestCovisibilityKeyFrames(params.covisible);
  keyframes.insert(keyframes.begin(), reference);
  MatcherT matcher(0.9f, true);
  std::set<MapPointT*> found;
  int matches = 0;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (keyframes[k]->isBad()) continue;
    matches += matcher.SearchByProjection(frame, keyframes[k], found, params.window, params.max_distance);
    for (std::size_t i = 0; i < frame.mvpMapPoints.size(); ++i)
      if (frame.mvpMapPoints[i]) found.insert(frame.mvpMapPoints[i]);
  }
  if (matches < params.min_inliers || place() < params.min_inliers) return giveUp();
  for (std::size_t i = 0; i < frame.mvpMapPoints.size(); ++i) {
    if (frame.mvpMapPoints[i] && frame.mvbOutlier[i]) {
      frame.mvpMapPoints[i] = static_cast<MapPointT*>(0);
      frame.mvbOutlier[i] = false;
    }
  }
  return true;
}

}  // namespace orbslam3
}  // namespace rvwo
