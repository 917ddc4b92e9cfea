// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// A new ORB-SLAM3 keyframe to RVWO's segmenter (WheelInput::keyFrame): its image and the keypoints
// that see map points, whose reliabilities its labels then update (eqs. 4, 5). Called by the
// patched Tracking::CreateNewKeyFrame (C++11); templated on ORB-SLAM3's KeyFrame so that no
// ORB-SLAM3 header is needed here.
#pragma once

#include <cstddef>
#include <vector>

#include "rvwo/orbslam3/wheel_input.h"

namespace rvwo {
namespace orbslam3 {

// image: the frame's as tracked (ORB-SLAM3's mImGray: the left one of a stereo pair), where the
// keyframe's keypoints (mvKeys, not undistorted) lie; the segmenter sees its colour original when
// the patched Grab* gave it (WheelInput::frameImage).
template <class KeyFrameT, class ImageT>
void sendKeyFrame(WheelInput& wheels, KeyFrameT& keyframe, const ImageT& image) {
  if (!wheels.segments()) return;
  const auto points = keyframe.GetMapPointMatches();
  std::vector<KeyFrameFeature> features;
  for (std::size_t i = 0; i < points.size() && i < keyframe.mvKeys.size(); ++i) {
    if (!points[i] || points[i]->isBad()) continue;
    const KeyFrameFeature f = {keyframe.mvKeys[i].pt.x, keyframe.mvKeys[i].pt.y, points[i]->mnId};
    features.push_back(f);
  }
  wheels.keyFrame(keyframe.mTimeStamp, image, features);
}

}  // namespace orbslam3
}  // namespace rvwo
