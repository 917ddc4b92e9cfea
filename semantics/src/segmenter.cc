// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/segmenter.h"

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "rvwo/semantics/image_file.h"

namespace rvwo {

cv::Mat toBgr(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("segmenter: empty image");
  if (image.depth() != CV_8U || (image.channels() != 3 && image.channels() != 1)) {
    throw std::invalid_argument("segmenter: expected an 8-bit BGR or grey image, got type " +
                                std::to_string(image.type()));
  }
  if (image.channels() == 3) return image;
  cv::Mat bgr;
  cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

LabelImageSegmenter::LabelImageSegmenter(const std::string& folder, std::vector<std::string> class_names,
                                         std::map<int, int> value_to_label, double tolerance_s)
    : class_names_(std::move(class_names)), value_to_label_(std::move(value_to_label)), tolerance_(tolerance_s) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw std::invalid_argument("label images: folder '" + folder + "' not found");
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (entry.path().extension() != ".png") continue;
    const std::string stem = entry.path().stem().string();
    char* end = nullptr;
    const double t = std::strtod(stem.c_str(), &end);
    if (end != stem.c_str() && *end == '\0' && std::isfinite(t)) files_[t] = entry.path().string();
  }
  if (files_.empty()) throw std::invalid_argument("label images: no <timestamp>.png in '" + folder + "'");
}

Segmentation LabelImageSegmenter::segment(const cv::Mat& image, const FrameInfo& info) {
  auto it = files_.lower_bound(info.timestamp);
  auto best = files_.end();
  if (it != files_.end()) best = it;
  if (it != files_.begin()) {
    auto prev = std::prev(it);
    if (best == files_.end() || info.timestamp - prev->first < best->first - info.timestamp) best = prev;
  }
  if (best == files_.end() || std::fabs(best->first - info.timestamp) > tolerance_) {
    throw std::runtime_error("label images: none within " + std::to_string(tolerance_) +
                             " s of t=" + std::to_string(info.timestamp));
  }
  cv::Mat raw;
  try {
    raw = readImageFile(best->second, cv::IMREAD_UNCHANGED);  // checked first: no libpng text on stderr
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("label images: ") + e.what());
  }
  if (raw.channels() != 1) {
    throw std::runtime_error("label images: cannot read '" + best->second + "' as a one-channel image");
  }
  if (!image.empty() && raw.size() != image.size()) {
    throw std::runtime_error("label images: '" + best->second + "' is " + std::to_string(raw.cols) + "x" +
                             std::to_string(raw.rows) + ", the image " + std::to_string(image.cols) + "x" +
                             std::to_string(image.rows));
  }
  Segmentation out;
  raw.convertTo(out.labels, CV_32S);
  if (!value_to_label_.empty()) {
    for (int y = 0; y < out.labels.rows; ++y) {
      int* row = out.labels.ptr<int>(y);
      for (int x = 0; x < out.labels.cols; ++x) {
        const auto m = value_to_label_.find(row[x]);
        row[x] = m == value_to_label_.end() ? -1 : m->second;
      }
    }
  }
  return out;
}

}  // namespace rvwo
