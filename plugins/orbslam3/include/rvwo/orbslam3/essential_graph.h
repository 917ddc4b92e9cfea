// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// Loop closing's pose graph on SE(2) (WheelInput::optimiseEssentialGraph) in place of ORB-SLAM3's
// Optimizer::OptimizeEssentialGraph for a stereo or RGB-D map (fixed scale), with its contract:
// - the same graph: every keyframe of the map (its first fixed), started at the loop's corrected
//   pose (CorrectedSim3) or where it is; vision's relative poses from the poses before the
//   correction (NonCorrectedSim3) along the spanning tree, the loop edges and the covisibility
//   edges of 100 shared points or more, and the new loop connections from the corrected poses;
// - the same write-back under the map's update mutex: each keyframe's pose, and each map point
//   moved with the keyframe it is referred to (the loop's own reference for the points the loop
//   corrected).
// What differs: poses on the plane (a loop's 6-DoF correction does not tilt the map), and wheel
// edges between keyframes consecutive in time (eq. 14) beside vision's, so the loop's error goes
// where the wheels and vision together are least sure, not evenly along the graph.
//
// Called by the patched LoopClosing.cc (C++11); templated on ORB-SLAM3's Map, KeyFrame and
// LoopClosing::KeyFrameAndPose (a map of KeyFrame* to g2o::Sim3, read through rotation(),
// translation() and scale()), so that no ORB-SLAM3 header is needed here. False, having done
// nothing, for ORB-SLAM3's own to run instead: as optimiseLocalMap, or LoopClosing.Planar 0.
#pragma once

#include <algorithm>
#include <cstddef>
#include <map>
#include <mutex>
#include <set>
#include <type_traits>
#include <utility>
#include <vector>

#include "rvwo/orbslam3/rig.h"
#include "rvwo/orbslam3/se3.h"
#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

namespace detail {

// T_c_w of a g2o::Sim3 S_c_w: [R t/s] (ORB-SLAM3's own recovery of an SE(3) pose).
template <class Sim3T>
Eigen::Isometry3d isometryOfSim3(const Sim3T& S) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = S.rotation().toRotationMatrix();
  T.translation() = S.translation() / S.scale();
  return T;
}

}  // namespace detail

template <class MapT, class KeyFrameT, class PosesT, class ConnectionsT>
bool optimiseEssentialGraph(WheelInput& wheels, MapT* map, KeyFrameT* loop_kf, KeyFrameT* current_kf,
                            const PosesT& non_corrected, const PosesT& corrected,
                            const ConnectionsT& loop_connections) {
  typedef typename std::remove_pointer<typename std::decay<decltype(map->GetAllMapPoints()[0])>::type>::type MapPointT;
  typedef typename std::decay<decltype(current_kf->GetPose())>::type PoseT;
  if (!wheels.optimisesEssentialGraphs() || !onePinhole(*current_kf)) return false;
  const int kMinShared = 100;  // ORB-SLAM3's covisibility bar for an edge of the essential graph

  std::vector<KeyFrameT*> keyframes;
  std::map<KeyFrameT*, int> index;
  EssentialGraph graph;
  std::vector<Eigen::Isometry3d> start, before;  // where the graph starts each; where it was before the correction
  const std::vector<KeyFrameT*> all = map->GetAllKeyFrames();
  for (std::size_t k = 0; k < all.size(); ++k) {
    KeyFrameT* kf = all[k];
    if (kf->isBad()) continue;
    const typename PosesT::const_iterator c = corrected.find(kf), n = non_corrected.find(kf);
    const Eigen::Isometry3d T = c != corrected.end() ? detail::isometryOfSim3(c->second) : isometryOf(kf->GetPose());
    const GraphKeyFrame g = {kf->mnId, kf->mTimeStamp, T, kf->mnId == map->GetInitKFid()};
    index[kf] = static_cast<int>(keyframes.size());
    keyframes.push_back(kf);
    graph.keyframes.push_back(g);
    start.push_back(T);
    before.push_back(n != non_corrected.end() ? detail::isometryOfSim3(n->second) : T);
  }
  std::set<std::pair<int, int> > joined;  // (lower, higher index)
  // From the poses the graph starts at (the new loop connections) or those before the correction.
  const auto join = [&](int i, int j, const std::vector<Eigen::Isometry3d>& poses) {
    const GraphEdge e = {i, j, poses[j] * poses[i].inverse()};
    graph.edges.push_back(e);
    joined.insert(std::make_pair(std::min(i, j), std::max(i, j)));
  };
  for (typename ConnectionsT::const_iterator it = loop_connections.begin(); it != loop_connections.end(); ++it) {
    const typename std::map<KeyFrameT*, int>::const_iterator i = index.find(it->first);
    if (i == index.end()) continue;
    for (typename ConnectionsT::mapped_type::const_iterator s = it->second.begin(); s != it->second.end(); ++s) {
      const typename std::map<KeyFrameT*, int>::const_iterator j = index.find(*s);
      if (j == index.end()) continue;
      if (!(it->first == current_kf && *s == loop_kf) && it->first->GetWeight(*s) < kMinShared) continue;
      join(i->second, j->second, start);
    }
  }
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    KeyFrameT* kf = keyframes[k];
    const int i = static_cast<int>(k);
    KeyFrameT* parent = kf->GetParent();
    if (parent && index.count(parent)) join(i, index[parent], before);  // spanning tree
    const std::set<KeyFrameT*> loops = kf->GetLoopEdges();
    for (typename std::set<KeyFrameT*>::const_iterator l = loops.begin(); l != loops.end(); ++l)
      if ((*l)->mnId < kf->mnId && index.count(*l)) join(i, index[*l], before);
    const std::vector<KeyFrameT*> covisible = kf->GetCovisiblesByWeight(kMinShared);
    for (std::size_t c = 0; c < covisible.size(); ++c) {
      KeyFrameT* n = covisible[c];
      if (!n || n == parent || kf->hasChild(n) || n->mnId >= kf->mnId || !index.count(n)) continue;
      const int j = index[n];
      if (!joined.count(std::make_pair(std::min(i, j), std::max(i, j)))) join(i, j, before);
    }
  }

  EssentialGraphSolution solution;
  if (!wheels.optimiseEssentialGraph(graph, &solution)) return false;

  std::unique_lock<std::mutex> lock(map->mMutexMapUpdate);
  for (std::size_t k = 0; k < keyframes.size(); ++k) keyframes[k]->SetPose(poseOf<PoseT>(solution.T_c_w[k]));
  // A point moves with its keyframe: from where the graph started it to where it put it.
  std::map<unsigned long, int> by_id;
  for (std::size_t k = 0; k < keyframes.size(); ++k) by_id[keyframes[k]->mnId] = static_cast<int>(k);
  const std::vector<MapPointT*> points = map->GetAllMapPoints();
  for (std::size_t p = 0; p < points.size(); ++p) {
    MapPointT* mp = points[p];
    if (mp->isBad()) continue;
    unsigned long reference;
    if (mp->mnCorrectedByKF == current_kf->mnId) {
      reference = mp->mnCorrectedReference;
    } else {
      KeyFrameT* r = mp->GetReferenceKeyFrame();
      if (!r) continue;
      reference = r->mnId;
    }
    const std::map<unsigned long, int>::const_iterator r = by_id.find(reference);
    if (r == by_id.end()) continue;
    const Eigen::Isometry3d move = solution.T_c_w[r->second].inverse() * start[r->second];
    mp->SetWorldPos(Eigen::Vector3f((move * mp->GetWorldPos().template cast<double>()).template cast<float>()));
    mp->UpdateNormalAndDepth();
  }
  map->IncreaseChangeIndex();
  return true;
}

}  // namespace orbslam3
}  // namespace rvwo
