// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// The pose of an ORB-SLAM3 frame on SE(2) (WheelInput::optimisePose) in place of ORB-SLAM3's
// 6-DoF Optimizer::PoseOptimization, with the same contract: it reads the frame's matches
// (mvpMapPoints), writes its pose and mvbOutlier, and returns the inliers. Included by the
// patched Tracking.cc (C++11); templated on ORB-SLAM3's Frame so that no ORB-SLAM3 header is
// needed here (nor Sophus: se3.h). Falls back to `upstream` (Optimizer::PoseOptimization) for
// a monocular map not in metres (WheelInput::monocularScale), a camera other than one pinhole
// (rig.h), or fewer than 3 matches.
#pragma once

#include <cstddef>
#include <mutex>
#include <type_traits>
#include <vector>

#include "rvwo/orbslam3/rig.h"
#include "rvwo/orbslam3/se3.h"
#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

template <class FrameT>
int optimisePose(WheelInput& wheels, FrameT& frame, const FrameT& last, int (*upstream)(FrameT*)) {
  if (!wheels.optimisesPoses() || !onePinhole(frame)) return upstream(&frame);
  PoseProblem p;
  p.t = frame.mTimeStamp;
  p.T_c_w = isometryOf(frame.GetPose());
  p.has_previous = last.HasPose();
  p.t_previous = last.mTimeStamp;
  p.T_cp_w = p.has_previous ? isometryOf(last.GetPose()) : Eigen::Isometry3d::Identity();
  p.fx = FrameT::fx;
  p.fy = FrameT::fy;
  p.cx = FrameT::cx;
  p.cy = FrameT::cy;
  p.bf = frame.mbf;
  p.scale_factor = frame.mfScaleFactor;
  std::vector<int> index;
  {
    // Map points move under local BA: read them as PoseOptimization does.
    typedef typename std::remove_pointer<typename std::decay<decltype(frame.mvpMapPoints[0])>::type>::type MapPointT;
    std::unique_lock<std::mutex> lock(MapPointT::mGlobalMutex);
    for (int i = 0; i < frame.N; ++i) {
      MapPointT* mp = frame.mvpMapPoints[i];
      if (!mp) continue;
      PoseMatch m;
      m.P_w = mp->GetWorldPos().template cast<double>();
      m.u = frame.mvKeysUn[i].pt.x;
      m.v = frame.mvKeysUn[i].pt.y;
      m.u_right = frame.mvuRight[i];
      m.level = frame.mvKeysUn[i].octave;
      m.id = mp->mnId;
      p.matches.push_back(m);
      index.push_back(i);
    }
  }
  PoseSolution s;
  if (!wheels.optimisePose(p, &s)) return upstream(&frame);
  frame.SetPose(poseOf<typename std::decay<decltype(frame.GetPose())>::type>(s.T_c_w));
  for (std::size_t k = 0; k < index.size(); ++k) frame.mvbOutlier[index[k]] = s.outlier[k] != 0;
  return s.inliers;
}

}  // namespace orbslam3
}  // namespace rvwo
