// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// An ONNX segmentation network on ONNX Runtime (CPU). The model is checked when it is loaded:
// a mismatch between the options and the model (input rank, size, element type, channel count,
// number of classes against the label set) is one std::invalid_argument naming what was expected
// and what was found. The shared DeepLabV3-MobileNetV2 (VOC-21) model, for instance:
//
//   OnnxSegmenterOptions o;
//   o.model_path = "deeplabv3_mnv2_voc21.onnx";
//   o.class_names = SemanticPriors::builtin("voc21").classes();   // (x - 127.5) / 127.5, RGB, NCHW:
//   OnnxSegmenter seg(o);                                          // the defaults
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "rvwo/semantics/segmenter.h"

namespace rvwo {

struct OnnxSegmenterOptions {
  std::string model_path;
  std::string input_name;   // empty: the model's first input
  std::string output_name;  // empty: the model's first output
  // Network input size in pixels; 0: the model's own (it must then be fixed in the model).
  int input_width = 0;
  int input_height = 0;
  enum class Layout { kNCHW, kNHWC } layout = Layout::kNCHW;
  enum class ColourOrder { kRGB, kBGR } colour_order = ColourOrder::kRGB;
  // value = (pixel - mean) * scale, per channel in the network's colour order.
  std::array<float, 3> mean{127.5f, 127.5f, 127.5f};
  std::array<float, 3> scale{1.0f / 127.5f, 1.0f / 127.5f, 1.0f / 127.5f};
  // kScores: per-class scores [1, C, h, w] (label = argmax); kLabels: class ids [1, h, w] or [1, 1, h, w].
  enum class Output { kScores, kLabels } output = Output::kScores;
  int intra_op_threads = 1;
  bool confidence = false;  // softmax probability of the label (kScores only)
  // The label set the network speaks, by class id (e.g. SemanticPriors::builtin("voc21").classes()).
  std::vector<std::string> class_names;
};

class OnnxSegmenter final : public Segmenter {
 public:
  explicit OnnxSegmenter(const OnnxSegmenterOptions& options);
  ~OnnxSegmenter() override;
  OnnxSegmenter(const OnnxSegmenter&) = delete;
  OnnxSegmenter& operator=(const OnnxSegmenter&) = delete;

  Segmentation segment(const cv::Mat& image, const FrameInfo& info = {}) override;
  const std::vector<std::string>& classNames() const override;
  int inputWidth() const;
  int inputHeight() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rvwo
