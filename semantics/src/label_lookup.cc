// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/label_lookup.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace rvwo {

LabelLookup::LabelLookup(const Segmentation& segmentation, const std::vector<int>& dynamic_labels,
                         int dilation_radius_px)
    : labels_(segmentation.labels) {
  if (labels_.empty() || labels_.type() != CV_32S) throw std::invalid_argument("LabelLookup: labels must be CV_32S");
  if (dilation_radius_px < 0) throw std::invalid_argument("LabelLookup: dilation radius must be >= 0");
  const int d = 2 * dilation_radius_px + 1;
  const cv::Mat disk = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(d, d));
  for (int label : dynamic_labels) {
    const cv::Mat mask = labels_ == label;
    if (cv::countNonZero(mask) == 0) continue;  // not in this image: no cost
    cv::Mat dilated;
    if (dilation_radius_px > 0) {
      cv::dilate(mask, dilated, disk);
    } else {
      dilated = mask;
    }
    dilated_.emplace_back(label, dilated);
  }
}

int LabelLookup::labelAt(const cv::Point2f& keypoint) const {
  const int x = static_cast<int>(std::floor(keypoint.x)), y = static_cast<int>(std::floor(keypoint.y));
  if (x < 0 || y < 0 || x >= labels_.cols || y >= labels_.rows) return -1;
  for (const auto& [label, mask] : dilated_) {
    if (mask.at<uint8_t>(y, x)) return label;
  }
  return labels_.at<int>(y, x);
}

}  // namespace rvwo
