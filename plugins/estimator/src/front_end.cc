// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The front end: a frame's features, their stereo matches or depth.
#include "impl.h"

namespace rvwo::estimator {

Estimator::Impl::FrontEnd Estimator::Impl::frontEnd(const FrameInput& in) {
  FrontEnd out;
  auto t0 = Clock::now();
  Features& f = out.f;
  const cv::Mat raw_grey = toGrey(in.image);
  out.raw_image = in.image;
  cv::Mat grey = raw_grey, grey_right = rig.sensor == Sensor::kStereo ? toGrey(in.right) : cv::Mat();
  if (rig.rectification) {
    const cv::Mat raw_right = grey_right;
    grey = cv::Mat();  // fresh buffers: cv::remap cannot work in place
    grey_right = cv::Mat();
    rig.rectification->rectify(raw_grey, raw_right, &grey, &grey_right);
  }
  if (rig.sensor == Sensor::kStereo) {
    f = extractor.extract(grey);
    timings.add("features", msSince(t0));
    auto t1 = Clock::now();
    matchStereo(grey, grey_right, rig.bf(), 0.5, rig.bf() / 0.2, &f);
    timings.add("stereo", msSince(t1));
  } else {
    f = extractor.extract(grey);
    if (rig.sensor == Sensor::kRgbd)
      depthFromImage(rig.rectification ? rig.rectification->rectifyLeftDepth(in.depth) : in.depth, rig.depth_factor,
                     rig.bf(), &f);
    timings.add("features", msSince(t0));
  }
  return out;
}

cv::Mat Estimator::Impl::toGrey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

}  // namespace rvwo::estimator
