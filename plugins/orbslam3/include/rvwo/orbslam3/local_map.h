// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// The local map of a new ORB-SLAM3 keyframe on SE(2) (WheelInput::optimiseLocalMap) in place of
// ORB-SLAM3's 6-DoF Optimizer::LocalBundleAdjustment, with the same contract: the same keyframes
// free (the new one and its covisible ones) and fixed (the map's first, and those that see the
// local points only), the same outlier observations erased (beyond the chi2 gate or behind the
// camera), poses and points written back under the map's update mutex, the abort flag obeyed.
// What differs: keyframe poses on the plane, each point under its adaptive Barron kernel (eqs.
// 6, 7; a rejected one, alpha -inf, stays where it is), out-of-plane noise (eq. 10), and wheel
// edges between keyframes consecutive in time (eq. 14).
//
// optimiseGlobalMap does the same for the whole map after a loop closed, in place of
// Optimizer::GlobalBundleAdjustemnt (its contract below).
//
// Called by the patched LocalMapping.cc and LoopClosing.cc (C++11); templated on ORB-SLAM3's
// KeyFrame and Map so that no ORB-SLAM3 header is needed here (nor Sophus: poses are read through
// rotationMatrix() and translation(), and made from a quaternion and a translation, as
// Sophus::SE3f is). Both return false, having done nothing, for ORB-SLAM3's own to run instead: a
// monocular map not in metres (WheelInput::monocularScale), a camera other than one pinhole (rig.h), RVWO's
// keys absent or LocalMapping.Planar 0.
#pragma once

#include <cstddef>
#include <map>
#include <mutex>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "rvwo/orbslam3/rig.h"
#include "rvwo/orbslam3/se3.h"
#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

namespace detail {

// The problem of these keyframes (the first n_free free unless the map's first) and points, and
// which keyframe and point each observation joins.
template <class KeyFrameT, class MapPointT>
void makeProblem(const std::vector<KeyFrameT*>& keyframes, std::size_t n_free, unsigned long first,
                 const std::vector<MapPointT*>& points, LocalMapProblem* problem,
                 std::vector<std::pair<KeyFrameT*, MapPointT*> >* seen_by) {
  problem->scale_factor = keyframes.front()->mfScaleFactor;
  std::map<KeyFrameT*, int> index;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    KeyFrameT* kf = keyframes[k];
    const MapKeyFrame m = {
        kf->mnId, kf->mTimeStamp, isometryOf(kf->GetPose()), k >= n_free || kf->mnId == first, kf->fx, kf->fy, kf->cx,
        kf->cy,   kf->mbf};
    problem->keyframes.push_back(m);
    index[kf] = static_cast<int>(k);
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    const MapPointEstimate p = {points[i]->mnId, points[i]->GetWorldPos().template cast<double>()};
    problem->points.push_back(p);
    const std::map<KeyFrameT*, std::tuple<int, int> > observations = points[i]->GetObservations();
    for (typename std::map<KeyFrameT*, std::tuple<int, int> >::const_iterator it = observations.begin();
         it != observations.end(); ++it) {
      const typename std::map<KeyFrameT*, int>::const_iterator k = index.find(it->first);
      const int left = std::get<0>(it->second);
      if (k == index.end() || left < 0) continue;
      const MapObservation o = {k->second,
                                static_cast<int>(i),
                                it->first->mvKeysUn[left].pt.x,
                                it->first->mvKeysUn[left].pt.y,
                                it->first->mvuRight[left],
                                it->first->mvKeysUn[left].octave};
      problem->observations.push_back(o);
      seen_by->push_back(std::make_pair(it->first, points[i]));
    }
  }
}

}  // namespace detail

template <class KeyFrameT, class MapT>
bool optimiseLocalMap(WheelInput& wheels, KeyFrameT* keyframe, bool* stop, MapT* map) {
  if (!wheels.optimisesLocalMaps() || !onePinhole(*keyframe)) return false;
  typedef typename std::remove_pointer<typename std::decay<decltype(keyframe->GetMapPointMatches()[0])>::type>::type
      MapPointT;
  typedef typename std::decay<decltype(keyframe->GetPose())>::type PoseT;
  const unsigned long id = keyframe->mnId;

  // Local keyframes: the new one and its covisible ones in the same map.
  std::vector<KeyFrameT*> keyframes(1, keyframe);
  keyframe->mnBALocalForKF = id;
  const std::vector<KeyFrameT*> neighbours = keyframe->GetVectorCovisibleKeyFrames();
  for (std::size_t i = 0; i < neighbours.size(); ++i) {
    neighbours[i]->mnBALocalForKF = id;
    if (!neighbours[i]->isBad() && neighbours[i]->GetMap() == map) keyframes.push_back(neighbours[i]);
  }
  const std::size_t n_local = keyframes.size();
  // Local points: those the local keyframes see.
  std::vector<MapPointT*> points;
  for (std::size_t k = 0; k < n_local; ++k) {
    const std::vector<MapPointT*> seen = keyframes[k]->GetMapPointMatches();
    for (std::size_t i = 0; i < seen.size(); ++i) {
      MapPointT* mp = seen[i];
      if (!mp || mp->isBad() || mp->GetMap() != map || mp->mnBALocalForKF == id) continue;
      mp->mnBALocalForKF = id;
      points.push_back(mp);
    }
  }
  // Fixed keyframes: those that see local points and are not local.
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::map<KeyFrameT*, std::tuple<int, int> > observations = points[i]->GetObservations();
    for (typename std::map<KeyFrameT*, std::tuple<int, int> >::const_iterator it = observations.begin();
         it != observations.end(); ++it) {
      KeyFrameT* k = it->first;
      if (k->mnBALocalForKF == id || k->mnBAFixedForKF == id) continue;
      k->mnBAFixedForKF = id;
      if (!k->isBad() && k->GetMap() == map) keyframes.push_back(k);
    }
  }
  const unsigned long first = map->GetInitKFid();
  bool held = keyframes.size() > n_local;
  for (std::size_t k = 0; k < n_local; ++k) held = held || keyframes[k]->mnId == first;
  if (!held) return true;  // as ORB-SLAM3: nothing holds the map, nothing is done

  LocalMapProblem problem;
  std::vector<std::pair<KeyFrameT*, MapPointT*> > seen_by;  // per observation
  detail::makeProblem(keyframes, n_local, first, points, &problem, &seen_by);
  if (stop && *stop) return true;
  LocalMapSolution solution;
  if (!wheels.optimiseLocalMap(problem, &solution, stop)) return false;

  std::unique_lock<std::mutex> lock(map->mMutexMapUpdate);
  for (std::size_t k = 0; k < seen_by.size(); ++k) {
    if (!solution.outlier[k] || seen_by[k].second->isBad()) continue;
    seen_by[k].first->EraseMapPointMatch(seen_by[k].second);
    seen_by[k].second->EraseObservation(seen_by[k].first);
  }
  for (std::size_t k = 0; k < n_local; ++k)
    if (!problem.keyframes[k].fixed) keyframes[k]->SetPose(poseOf<PoseT>(solution.T_c_w[k]));
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i]->SetWorldPos(Eigen::Vector3f(solution.P_w[i].cast<float>()));
    points[i]->UpdateNormalAndDepth();
  }
  map->IncreaseChangeIndex();
  return true;
}

// The whole map on SE(2) after a loop closed (WheelInput::optimiseLocalMap over every keyframe,
// the map's first fixed), in place of ORB-SLAM3's Optimizer::GlobalBundleAdjustemnt, with its
// contract: for the loop of keyframe loop_kf, results go to mTcwGBA and mPosGBA (marked
// mnBAGlobalForKF = loop_kf; keyframes and points left out, rejected points among them, are not
// marked and follow their parent's or reference keyframe's correction), or straight into the map when loop_kf is the
// map's origin keyframe. Nothing is erased. False, having done nothing, as optimiseLocalMap.
template <class MapT>
bool optimiseGlobalMap(WheelInput& wheels, MapT* map, bool* stop, unsigned long loop_kf) {
  typedef typename std::remove_pointer<typename std::decay<decltype(map->GetAllKeyFrames()[0])>::type>::type KeyFrameT;
  typedef typename std::remove_pointer<typename std::decay<decltype(map->GetAllMapPoints()[0])>::type>::type MapPointT;
  typedef typename std::decay<decltype(map->GetOriginKF()->GetPose())>::type PoseT;
  if (!wheels.optimisesLocalMaps()) return false;
  std::vector<KeyFrameT*> keyframes;
  const std::vector<KeyFrameT*> all = map->GetAllKeyFrames();
  for (std::size_t k = 0; k < all.size(); ++k)
    if (!all[k]->isBad()) keyframes.push_back(all[k]);
  if (keyframes.empty() || !onePinhole(*keyframes.front())) return false;
  std::vector<MapPointT*> points;
  const std::vector<MapPointT*> all_points = map->GetAllMapPoints();
  for (std::size_t i = 0; i < all_points.size(); ++i)
    if (!all_points[i]->isBad()) points.push_back(all_points[i]);
  LocalMapProblem problem;
  std::vector<std::pair<KeyFrameT*, MapPointT*> > seen_by;
  detail::makeProblem(keyframes, keyframes.size(), map->GetInitKFid(), points, &problem, &seen_by);
  LocalMapSolution solution;
  if (!wheels.optimiseLocalMap(problem, &solution, stop)) return false;
  const bool into_map = loop_kf == map->GetOriginKF()->mnId;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    // A free keyframe the problem could not place (it sees no point and no wheel edge reaches it,
    // e.g. its readings are older than those kept) is left unmarked: the loop closer then moves
    // it with its parent in the spanning tree, as it moves a keyframe made during the global BA.
    // Marked, it would keep its old pose while the map around it moved.
    if (!solution.placed[k] && !problem.keyframes[k].fixed) continue;
    const PoseT T = poseOf<PoseT>(solution.T_c_w[k]);
    if (into_map) {
      keyframes[k]->SetPose(T);
    } else {
      keyframes[k]->mTcwGBA = T;
      keyframes[k]->mnBAGlobalForKF = loop_kf;
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!solution.solved[i]) continue;
    const Eigen::Vector3f P(solution.P_w[i].cast<float>());
    if (into_map) {
      points[i]->SetWorldPos(P);
      points[i]->UpdateNormalAndDepth();
    } else {
      points[i]->mPosGBA = P;
      points[i]->mnBAGlobalForKF = loop_kf;
    }
  }
  return true;
}

}  // namespace orbslam3
}  // namespace rvwo
