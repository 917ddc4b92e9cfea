// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// Segmenters the ORB-SLAM3 plugin's tests give keyframes to.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/semantics/segmenter.h"

namespace rvwo::test {

// Labels a person (voc21's 15) on the left half of every image, background on the right; counts
// the images it was given.
class HalfPerson final : public rvwo::Segmenter {
 public:
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    rvwo::Segmentation s;
    s.labels = cv::Mat::zeros(image.rows, image.cols, CV_32S);
    s.labels(cv::Rect(0, 0, image.cols / 2, image.rows)).setTo(person_);
    ++calls;
    return s;
  }
  const std::vector<std::string>& classNames() const override { return names_; }
  int calls = 0;

 private:
  std::vector<std::string> names_ = rvwo::SemanticPriors::builtin("voc21").classes();
  int person_ = rvwo::SemanticPriors::builtin("voc21").labelOf("person");
};

}  // namespace rvwo::test
