// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-segment: runs an ONNX segmentation network on one image, the way RVWO's segmentation
// thread does, and shows what it sees. Writes the label image (8-bit PNG, one class id per pixel;
// 16-bit when the label set has more than 255 classes), optionally an overlay a person can look at,
// and prints the fraction of pixels of each class found and the time per frame.
//
//   rvwo-segment --image rgb.png --out labels.png --overlay overlay.png       (the shipped network)
//   rvwo-segment --model net.onnx --labels ade20k150 --image rgb.png --out labels.png
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/semantics/image_file.h"
#include "rvwo/semantics/onnx_segmenter.h"
#include "rvwo/semantics/shipped_model.h"
#include "support/command_line.h"

namespace {

std::array<float, 3> triple(const std::string& text, const char* what) {
  std::array<float, 3> v{};
  std::istringstream in(text);
  char comma = 0;
  if (!(in >> v[0] >> comma >> v[1] >> comma >> v[2]) || !in.eof()) {
    throw std::invalid_argument(std::string("--") + what + ": expected three numbers a,b,c, got '" + text + "'");
  }
  return v;
}

// A distinct colour per class (golden-angle hues), brighter for dynamic classes.
cv::Vec3b colourOf(int label, bool dynamic) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar((label * 47) % 180, dynamic ? 255 : 140, dynamic ? 255 : 200)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr.at<cv::Vec3b>(0, 0);
}

// The command line, in the order --help lists it.
struct SegmentArgs {
  TCLAP::CmdLine cmd{
      "rvwo-segment: runs an ONNX segmentation network on an image and writes its label image; prints each class's "
      "share of the pixels and the time per frame. The defaults fit DeepLab-style networks: RGB, NCHW, "
      "(x - 127.5) / 127.5, class scores out.",
      ' ', RVWO_VERSION};
  TCLAP::ValueArg<std::string> model{
      "",    "model", "the ONNX model (default: the one RVWO ships, DeepLabV3 MobileNetV2 on VOC's 21 classes)",
      false, "",      "file.onnx",
      cmd};
  TCLAP::ValueArg<std::string> labels{
      "",     "labels", "the label set it speaks: voc21, coco80 or ade20k150 (needed with --model)", false, "",
      "name", cmd};
  TCLAP::ValueArg<std::string> image{"", "image", "the input image (any format OpenCV reads)", true, "", "file", cmd};
  TCLAP::ValueArg<std::string> out{"", "out", "the label image to write (PNG)", true, "", "labels.png", cmd};
  TCLAP::ValueArg<std::string> overlay{
      "", "overlay", "also write the image with the classes painted over it", false, "", "overlay.png", cmd};
  TCLAP::ValueArg<int> threads{"", "threads", "intra-op threads (default 2)", false, 2, "N", cmd};
  TCLAP::ValueArg<int> repeat{"", "repeat", "run N times and report the mean time (default 5)", false, 5, "N", cmd};
  TCLAP::ValueArg<std::string> layout{"", "layout", "nchw (default) or nhwc", false, "nchw", "layout", cmd};
  TCLAP::SwitchArg bgr{"", "bgr", "the network takes BGR, not RGB", cmd};
  TCLAP::ValueArg<std::string> mean{
      "", "mean", "per-channel mean (default 127.5,127.5,127.5)", false, "127.5,127.5,127.5", "a,b,c", cmd};
  TCLAP::ValueArg<std::string> scale{
      "",      "scale", "per-channel scale (default 1/127.5 each)", false, "0.00784313725,0.00784313725,0.00784313725",
      "a,b,c", cmd};
  TCLAP::SwitchArg label_output{"", "label-output", "the network outputs class ids, not class scores", cmd};
};

rvwo::OnnxSegmenterOptions optionsOf(SegmentArgs& args, const rvwo::SemanticPriors& priors) {
  rvwo::OnnxSegmenterOptions o;
  o.model_path = args.model.isSet() ? args.model.getValue() : rvwo::shippedModelPath();
  o.class_names = priors.classes();
  o.intra_op_threads = args.threads.getValue();
  if (args.layout.getValue() != "nchw" && args.layout.getValue() != "nhwc")
    throw std::invalid_argument("--layout: nchw or nhwc");
  o.layout = args.layout.getValue() == "nchw" ? rvwo::OnnxSegmenterOptions::Layout::kNCHW
                                              : rvwo::OnnxSegmenterOptions::Layout::kNHWC;
  o.colour_order = args.bgr.getValue() ? rvwo::OnnxSegmenterOptions::ColourOrder::kBGR
                                       : rvwo::OnnxSegmenterOptions::ColourOrder::kRGB;
  o.mean = triple(args.mean.getValue(), "mean");
  o.scale = triple(args.scale.getValue(), "scale");
  if (args.label_output.getValue()) o.output = rvwo::OnnxSegmenterOptions::Output::kLabels;
  if (args.repeat.getValue() < 1) throw std::invalid_argument("--repeat: at least 1");
  return o;
}

// The image with its classes painted over it and a legend, classes in `order` (most pixels first).
cv::Mat paintOverlay(const cv::Mat& img, const cv::Mat& labels, const rvwo::SemanticPriors& priors,
                     const std::vector<int>& order, const std::vector<int>& count) {
  const std::vector<int> dynamic = priors.dynamicLabels(0.5);
  auto isDynamic = [&](int l) { return std::find(dynamic.begin(), dynamic.end(), l) != dynamic.end(); };
  cv::Mat painted = img.clone();
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const int l = labels.at<int>(y, x);
      if (l <= 0) continue;  // background (class 0 in every built-in set but COCO) stays as it is
      const cv::Vec3b c = colourOf(l, isDynamic(l));
      cv::Vec3b& p = painted.at<cv::Vec3b>(y, x);
      for (int k = 0; k < 3; ++k) p[k] = static_cast<uint8_t>(0.45 * p[k] + 0.55 * c[k]);
    }
  }
  int rows = 0;
  for (int l : order) rows += (count[l] > 0 && l != 0);
  if (rows > 0) {  // a dark backdrop so the legend reads on any image
    cv::Mat box = painted(cv::Rect(4, 4, std::min(painted.cols - 4, 200), std::min(painted.rows - 4, 22 * rows + 8)));
    box *= 0.35;
  }
  int row = 0;
  for (int l : order) {
    if (count[l] == 0 || l == 0) continue;
    const cv::Vec3b c = colourOf(l, isDynamic(l));
    cv::rectangle(painted, cv::Rect(10, 10 + 22 * row, 16, 16), cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
    cv::putText(painted, priors.className(l), cv::Point(32, 24 + 22 * row), cv::FONT_HERSHEY_SIMPLEX, 0.55,
                cv::Scalar(255, 255, 255), 2);
    ++row;
  }
  return painted;
}

// Segments the image (timed over --repeat runs after a warm-up), prints the class shares, writes
// the label image and the overlay.
int segmentImage(SegmentArgs& args) {
  if (args.model.isSet() && !args.labels.isSet())
    throw std::invalid_argument("--labels: name the label set --model speaks (voc21, coco80 or ade20k150)");
  if (!args.model.isSet() && args.labels.isSet() && args.labels.getValue() != rvwo::kShippedModelLabelSet)
    throw std::invalid_argument("--labels " + args.labels.getValue() + ": the shipped network speaks " +
                                rvwo::kShippedModelLabelSet + " (give --model for another network)");
  const rvwo::SemanticPriors priors =
      rvwo::SemanticPriors::builtin(args.labels.isSet() ? args.labels.getValue() : rvwo::kShippedModelLabelSet);
  rvwo::OnnxSegmenter seg(optionsOf(args, priors));  // checks the model first: its errors name what it expected
  const std::string& image = args.image.getValue();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(image, ec)) throw std::runtime_error("image '" + image + "' not found");
  const cv::Mat img = rvwo::readImageFile(image, cv::IMREAD_COLOR);
  rvwo::Segmentation s = seg.segment(img);  // warm-up, not timed
  const int repeat = args.repeat.getValue();
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < repeat; ++i) s = seg.segment(img);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / repeat;

  std::vector<int> count(priors.size(), 0);
  for (int y = 0; y < s.labels.rows; ++y) {
    for (int x = 0; x < s.labels.cols; ++x) {
      const int l = s.labels.at<int>(y, x);
      if (l >= 0 && l < static_cast<int>(count.size())) ++count[l];
    }
  }
  std::printf("%s: %dx%d -> network %dx%d, %.1f ms per frame (%d threads, mean of %d)\n", image.c_str(), img.cols,
              img.rows, seg.inputWidth(), seg.inputHeight(), ms, args.threads.getValue(), repeat);
  std::vector<int> order(count.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return count[a] > count[b]; });
  for (int l : order) {
    if (count[l] == 0) break;
    std::printf("  %5.1f %%  %-16s (class %d, P_prior %.2f)\n", 100.0 * count[l] / s.labels.total(),
                priors.className(l).c_str(), l, priors.prior(l));
  }

  cv::Mat label_img;
  s.labels.convertTo(label_img, priors.size() > 255 ? CV_16U : CV_8U);
  const std::string& out = args.out.getValue();
  if (!cv::imwrite(out, label_img)) throw std::runtime_error("cannot write '" + out + "'");
  const std::string& overlay = args.overlay.getValue();
  if (!overlay.empty() && !cv::imwrite(overlay, paintOverlay(img, s.labels, priors, order, count)))
    throw std::runtime_error("cannot write '" + overlay + "'");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-segment", [&] {
    SegmentArgs args;
    if (const auto status = rvwo::apps::parseCommandLine(args.cmd, argc, argv)) return *status;
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);  // our errors are one line each
    return segmentImage(args);
  });
}
