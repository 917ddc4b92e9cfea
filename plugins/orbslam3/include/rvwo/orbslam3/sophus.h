// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// WheelInput in ORB-SLAM3's pose type (Sophus::SE3f, as T_c_w). Included by the patched
// Tracking.cc, whose include path has ORB-SLAM3's bundled Sophus; C++11.
#pragma once

#include <sophus/se3.hpp>

#include "rvwo/orbslam3/se3.h"
#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

// T_cj_w of the frame at tj from T_ci_w of the frame at ti.
inline Sophus::SE3f predict(const WheelInput& wheels, const Sophus::SE3f& T_ci_w, double ti, double tj) {
  return poseOf<Sophus::SE3f>(wheels.predict(isometryOf(T_ci_w), ti, tj));
}

// WheelInput::monocularScale of ORB-SLAM3's two first monocular keyframes, as the factor
// CreateInitialMapMonocular applies (float).
template <class KeyFrameT>
float monocularScale(WheelInput& wheels, KeyFrameT* first, KeyFrameT* second) {
  return static_cast<float>(wheels.monocularScale(first->mTimeStamp, second->mTimeStamp, isometryOf(first->GetPose()),
                                                  isometryOf(second->GetPose())));
}

}  // namespace orbslam3
}  // namespace rvwo
