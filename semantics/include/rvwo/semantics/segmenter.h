// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The segmentation hook: an image in, a label image at the image's resolution out. Backends:
//   OnnxSegmenter        any ordinary ONNX segmentation network, on ONNX Runtime (onnx_segmenter.h)
//   LabelImageSegmenter  precomputed label images: a dataset's masks, the simulator's ground truth
// AsyncSegmenter (async_segmenter.h) runs one in its own thread; LabelLookup (label_lookup.h)
// gives a keypoint its label.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace rvwo {

// What a backend may need to know of a frame besides its pixels.
struct FrameInfo {
  std::uint64_t id = 0;
  double timestamp = 0.0;  // s
};

struct Segmentation {
  cv::Mat labels;      // CV_32S, the input image's size; class ids of the segmenter's label set
  cv::Mat confidence;  // CV_32F softmax probability of the label, when the backend gives one
};

class Segmenter {
 public:
  virtual ~Segmenter() = default;
  // image: 8-bit BGR (OpenCV's order), or 8-bit grey (treated as three equal channels).
  // Throws std::invalid_argument for an empty or wrongly typed image, std::runtime_error when the
  // backend fails.
  virtual Segmentation segment(const cv::Mat& image, const FrameInfo& info = {}) = 0;
  // The label set: class id -> name (feeds rvwo::SemanticPriors).
  virtual const std::vector<std::string>& classNames() const = 0;
};

// Reads label images named <timestamp>.png from a folder (the TUM style, e.g. 1341846313.592026.png)
// and returns the one nearest the frame's timestamp, within a tolerance. Pixel values are class ids,
// or are mapped through value_to_label (e.g. DynaSLAM's masks: 0 -> person, 1 -> background).
class LabelImageSegmenter final : public Segmenter {
 public:
  // Throws std::invalid_argument when the folder is missing or holds no <timestamp>.png.
  LabelImageSegmenter(const std::string& folder, std::vector<std::string> class_names,
                      std::map<int, int> value_to_label = {}, double tolerance_s = 0.02);
  // Throws std::runtime_error when no label image lies within the tolerance of info.timestamp,
  // or when it cannot be read or has the wrong size.
  Segmentation segment(const cv::Mat& image, const FrameInfo& info = {}) override;
  const std::vector<std::string>& classNames() const override { return class_names_; }
  std::size_t size() const { return files_.size(); }

 private:
  std::vector<std::string> class_names_;
  std::map<int, int> value_to_label_;
  double tolerance_;
  std::map<double, std::string> files_;  // timestamp -> path
};

// An 8-bit BGR image from an 8-bit BGR or grey one; throws std::invalid_argument otherwise.
cv::Mat toBgr(const cv::Mat& image);

}  // namespace rvwo
