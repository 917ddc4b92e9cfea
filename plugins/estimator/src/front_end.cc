// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The front end: a frame's features, their stereo matches or depth.
#include "front_end.h"

#include <opencv2/imgproc.hpp>

namespace rvwo::estimator {

FrontEnd::FrontEnd(Context& ctx)
    : ctx_(ctx),
      extractor_(FeatureParams{ctx.opt.features, ctx.opt.scale_factor, ctx.opt.levels, ctx.opt.fast_threshold, 8, 6}) {}

FrameFeatures FrontEnd::operator()(const FrameInput& in) const {
  FrameFeatures out;
  auto t0 = Clock::now();
  Features& f = out.f;
  const cv::Mat raw_grey = toGrey(in.image);
  out.raw_image = in.image;
  cv::Mat grey = raw_grey, grey_right = ctx_.rig.sensor == Sensor::kStereo ? toGrey(in.right) : cv::Mat();
  if (ctx_.rig.rectification) {
    const cv::Mat raw_right = grey_right;
    grey = cv::Mat();  // fresh buffers: cv::remap cannot work in place
    grey_right = cv::Mat();
    ctx_.rig.rectification->rectify(raw_grey, raw_right, &grey, &grey_right);
  }
  if (ctx_.rig.sensor == Sensor::kStereo) {
    f = extractor_.extract(grey);
    ctx_.timings.add("features", msSince(t0));
    auto t1 = Clock::now();
    matchStereo(grey, grey_right, ctx_.rig.bf(), 0.5, ctx_.rig.bf() / 0.2, &f);
    ctx_.timings.add("stereo", msSince(t1));
  } else {
    f = extractor_.extract(grey);
    if (ctx_.rig.sensor == Sensor::kRgbd)
      depthFromImage(ctx_.rig.rectification ? ctx_.rig.rectification->rectifyLeftDepth(in.depth) : in.depth,
                     ctx_.rig.depth_factor, ctx_.rig.bf(), &f);
    ctx_.timings.add("features", msSince(t0));
  }
  return out;
}

cv::Mat FrontEnd::toGrey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

}  // namespace rvwo::estimator
