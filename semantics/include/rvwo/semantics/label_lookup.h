// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The label under a keypoint. Around dynamic classes (people, ...) a dilation radius widens their
// masks, since segmentation borders are ragged and a keypoint on a person's outline is on the
// person (the authors' code used about 20 px). Each dynamic class present in the image is dilated
// once, so a lookup is O(number of dynamic classes present).
#pragma once

#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "rvwo/semantics/segmenter.h"

namespace rvwo {

class LabelLookup {
 public:
  // dynamic_labels in order of precedence (where two dilated masks overlap, the first wins).
  LabelLookup(const Segmentation& segmentation, const std::vector<int>& dynamic_labels, int dilation_radius_px);
  // The dynamic label whose dilated mask covers the pixel, else the pixel's own label; -1
  // outside the image.
  int labelAt(const cv::Point2f& keypoint) const;

 private:
  cv::Mat labels_;
  std::vector<std::pair<int, cv::Mat>> dilated_;  // dynamic label -> dilated mask (CV_8U)
};

}  // namespace rvwo
