// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-make-people: cuts the people out of a real RGB-D frame, as rvwo-sim's walkers wear them
// (apps/sim/people/README.md). The person label of a segmentation (rvwo-segment's output) is
// trimmed by depth: each person is the connected part of the label whose depth lies within
// kDepthBand of its median. Each person becomes person_<i>.png, colour with an alpha channel,
// cropped to them. Built on request: cmake --build build --target rvwo-make-people.
//   rvwo-make-people RGB.png DEPTH.png LABELS.png DEPTH_FACTOR OUT_DIR
#include <algorithm>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace {

constexpr int kPerson = 15;          // VOC-21
constexpr double kDepthBand = 0.45;  // m either side of a person's median depth
constexpr int kMinPixels = 5000;     // smaller parts are not a person

// The person of one connected part of the label: its pixels within the depth band of their median
// (given back in *median, m).
cv::Mat trimmedByDepth(const cv::Mat& part, const cv::Mat& depth_m, float* median_out) {
  std::vector<float> d;
  for (int y = 0; y < part.rows; ++y) {
    for (int x = 0; x < part.cols; ++x) {
      if (part.at<uint8_t>(y, x) && depth_m.at<float>(y, x) > 0) d.push_back(depth_m.at<float>(y, x));
    }
  }
  cv::Mat out = cv::Mat::zeros(part.size(), CV_8U);
  if (d.empty()) return out;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  const float median = d[d.size() / 2];
  *median_out = median;
  for (int y = 0; y < part.rows; ++y) {
    for (int x = 0; x < part.cols; ++x) {
      const float z = depth_m.at<float>(y, x);
      out.at<uint8_t>(y, x) = part.at<uint8_t>(y, x) && z > 0 && std::abs(z - median) < kDepthBand ? 255 : 0;
    }
  }
  cv::morphologyEx(out, out, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}));
  cv::morphologyEx(out, out, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, {9, 9}));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: rvwo-make-people RGB.png DEPTH.png LABELS.png DEPTH_FACTOR OUT_DIR\n");
    return 2;
  }
  const cv::Mat rgb = cv::imread(argv[1], cv::IMREAD_COLOR), depth = cv::imread(argv[2], cv::IMREAD_UNCHANGED),
                labels = cv::imread(argv[3], cv::IMREAD_GRAYSCALE);
  if (rgb.empty() || depth.empty() || labels.empty() || rgb.size() != depth.size() || rgb.size() != labels.size()) {
    std::fprintf(stderr, "rvwo-make-people: the three images must exist and have one size\n");
    return 1;
  }
  cv::Mat depth_m;
  depth.convertTo(depth_m, CV_32F, 1.0 / std::stod(argv[4]));
  cv::Mat parts;
  const int n = cv::connectedComponents(labels == kPerson, parts, 8, CV_32S);
  int written = 0;
  for (int i = 1; i < n; ++i) {
    float median = 0;
    const cv::Mat person = trimmedByDepth(parts == i, depth_m, &median);
    if (cv::countNonZero(person) < kMinPixels) continue;
    const cv::Rect box = cv::boundingRect(person);
    std::vector<cv::Mat> channels;
    cv::split(rgb(box), channels);
    channels.push_back(person(box).clone());
    cv::Mat sprite;
    cv::merge(channels, sprite);
    const std::string path = std::string(argv[5]) + "/person_" + std::to_string(written++) + ".png";
    if (!cv::imwrite(path, sprite)) {
      std::fprintf(stderr, "rvwo-make-people: cannot write %s\n", path.c_str());
      return 1;
    }
    std::printf("%s: %dx%d at (%d, %d), %d pixels, median depth %.3f m\n", path.c_str(), box.width, box.height, box.x,
                box.y, cv::countNonZero(person), median);
  }
  return written > 0 ? 0 : 1;
}
