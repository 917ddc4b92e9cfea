// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// Whether an ORB-SLAM3 frame or keyframe was seen by the one pinhole camera (rectified stereo and
// RGB-D included) the plugin's solvers model: its keypoints undistorted onto fx, fy, cx, cy. A
// two-camera rig (mpCamera2) or a single fisheye (KannalaBrandt8, whose keypoints stay distorted)
// is left to ORB-SLAM3's own optimisers. Templated on ORB-SLAM3's types (GeometricCamera's
// GetType, CAM_PINHOLE); C++11.
#pragma once

#include <type_traits>

namespace rvwo {
namespace orbslam3 {

template <class FrameT>
bool onePinhole(const FrameT& frame) {
  typedef typename std::remove_pointer<typename std::decay<decltype(frame.mpCamera)>::type>::type CameraT;
  return !frame.mpCamera2 && frame.mpCamera && frame.mpCamera->GetType() == CameraT::CAM_PINHOLE;
}

}  // namespace orbslam3
}  // namespace rvwo
