// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/estimator/features.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core/hal/hal.hpp>

namespace rvwo::estimator {

int hammingDistance(const cv::Mat& a, const cv::Mat& b) {
  return cv::hal::normHamming(a.ptr<uchar>(), b.ptr<uchar>(), a.cols);
}

void Features::buildGrid(int width, int height) {
  cols_ = (width + kCell - 1) / kCell;
  rows_ = (height + kCell - 1) / kCell;
  cells_.assign(static_cast<std::size_t>(cols_) * rows_, {});
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const int c = std::clamp(static_cast<int>(keypoints[i].pt.x) / kCell, 0, cols_ - 1);
    const int r = std::clamp(static_cast<int>(keypoints[i].pt.y) / kCell, 0, rows_ - 1);
    cells_[r * cols_ + c].push_back(static_cast<int>(i));
  }
}

std::vector<int> Features::near(float u, float v, float radius, int min_level, int max_level) const {
  std::vector<int> out;
  if (cells_.empty()) return out;
  const int c0 = std::max(0, static_cast<int>(std::floor((u - radius) / kCell)));
  const int c1 = std::min(cols_ - 1, static_cast<int>(std::floor((u + radius) / kCell)));
  const int r0 = std::max(0, static_cast<int>(std::floor((v - radius) / kCell)));
  const int r1 = std::min(rows_ - 1, static_cast<int>(std::floor((v + radius) / kCell)));
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      for (int i : cells_[r * cols_ + c]) {
        const cv::KeyPoint& k = keypoints[i];
        if (k.octave < min_level || k.octave > max_level) continue;
        const float du = k.pt.x - u, dv = k.pt.y - v;
        if (du * du + dv * dv <= radius * radius) out.push_back(i);
      }
    }
  }
  return out;
}

FeatureExtractor::FeatureExtractor(const FeatureParams& params) : params_(params) {
  // Twice the budget is detected, then shared out over the grid, so that texture-rich corners of
  // the image do not take every feature (ORB-SLAM's octree does the same job); only those kept
  // are described.
  orb_ = cv::ORB::create(2 * params.features, static_cast<float>(params.scale_factor), params.levels, 19, 0, 2,
                         cv::ORB::FAST_SCORE, 31, params.fast_threshold);
}

Features FeatureExtractor::extract(const cv::Mat& image) const {
  std::vector<cv::KeyPoint> all;
  orb_->detect(image, all);
  // Grid: each cell first takes its strongest keypoints up to an equal share; what is left of
  // the budget goes to the strongest of the rest.
  const int cells = params_.grid_cols * params_.grid_rows;
  const int share = std::max(1, params_.features / cells);
  std::vector<int> order(all.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return all[a].response > all[b].response; });
  std::vector<int> taken_in(cells, 0);
  std::vector<char> chosen(all.size(), 0);
  int n = 0;
  for (int i : order) {
    const int c = std::clamp(static_cast<int>(all[i].pt.x * params_.grid_cols / image.cols), 0, params_.grid_cols - 1);
    const int r = std::clamp(static_cast<int>(all[i].pt.y * params_.grid_rows / image.rows), 0, params_.grid_rows - 1);
    if (taken_in[r * params_.grid_cols + c] < share) {
      ++taken_in[r * params_.grid_cols + c];
      chosen[i] = 1;
      ++n;
    }
  }
  for (int i : order) {
    if (n >= params_.features) break;
    if (!chosen[i]) {
      chosen[i] = 1;
      ++n;
    }
  }
  Features f;
  f.keypoints.reserve(n);
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (chosen[i]) f.keypoints.push_back(all[i]);
  }
  // Described once chosen: half the detections never are (cv::ORB keeps the keypoints' order and
  // gives the descriptors detectAndCompute would; its border filter has nothing to drop here).
  orb_->compute(image, f.keypoints, f.descriptors);
  n = static_cast<int>(f.keypoints.size());
  if (f.descriptors.empty()) f.descriptors.create(0, 32, CV_8U);
  f.u_right.assign(n, -1.f);
  f.depth.assign(n, -1.f);
  f.buildGrid(image.cols, image.rows);
  return f;
}

namespace {

// Sum of absolute differences of (2h+1)^2 patches centred at (ul, v) in left and (ur, v) in right.
int patchSad(const cv::Mat& left, const cv::Mat& right, int ul, int ur, int v, int h) {
  int sad = 0;
  for (int dy = -h; dy <= h; ++dy) {
    const uchar* a = left.ptr<uchar>(v + dy) + ul - h;
    const uchar* b = right.ptr<uchar>(v + dy) + ur - h;
    for (int dx = 0; dx <= 2 * h; ++dx) sad += std::abs(int(a[dx]) - int(b[dx]));
  }
  return sad;
}

}  // namespace

void matchStereo(const cv::Mat& left_image, const cv::Mat& right_image, const Features& right, double bf,
                 double min_disparity, double max_disparity, Features* left) {
  // Right keypoints by image row, for the row-band search.
  const int rows = left_image.rows;
  std::vector<std::vector<int>> by_row(rows);
  for (std::size_t j = 0; j < right.keypoints.size(); ++j) {
    const cv::KeyPoint& k = right.keypoints[j];
    const float band = 2.0f * std::pow(1.2f, static_cast<float>(k.octave));
    const int r0 = std::max(0, static_cast<int>(std::floor(k.pt.y - band)));
    const int r1 = std::min(rows - 1, static_cast<int>(std::ceil(k.pt.y + band)));
    for (int r = r0; r <= r1; ++r) by_row[r].push_back(static_cast<int>(j));
  }
  constexpr int kMaxDistance = 60;
  for (std::size_t i = 0; i < left->keypoints.size(); ++i) {
    const cv::KeyPoint& kl = left->keypoints[i];
    const int row = std::clamp(static_cast<int>(std::lround(kl.pt.y)), 0, rows - 1);
    BestTwo match{kMaxDistance + 1};
    for (int j : by_row[row]) {
      const cv::KeyPoint& kr = right.keypoints[j];
      if (std::abs(kr.octave - kl.octave) > 1) continue;
      const double d = kl.pt.x - kr.pt.x;
      if (d < min_disparity || d > max_disparity) continue;
      match.offer(hammingDistance(left->descriptors.row(static_cast<int>(i)), right.descriptors.row(j)), j);
    }
    if (match.index < 0 || match.best > 0.9 * match.second) continue;
    const int best_j = match.index;
    // Sub-pixel: SAD of patches along the row, +-3 px around the match, then a parabola. The
    // patch grows with the keypoint's level (3 px half-width at level 0): a coarse corner's
    // position is only known to its level's pixel, and a small patch there may see flat grey.
    const int h = 3 + kl.octave;
    const int ul = static_cast<int>(std::lround(kl.pt.x)), v = row;
    const int ur0 = static_cast<int>(std::lround(right.keypoints[best_j].pt.x));
    double ur = right.keypoints[best_j].pt.x;
    if (v >= h && v < rows - h && ul >= h && ul < left_image.cols - h && ur0 - 4 >= h &&
        ur0 + 4 < right_image.cols - h) {
      int sad[9];
      for (int k = -4; k <= 4; ++k) sad[k + 4] = patchSad(left_image, right_image, ul, ur0 + k, v, h);
      int m = 1;
      for (int k = 2; k <= 7; ++k) {
        if (sad[k] < sad[m]) m = k;
      }
      const double a = sad[m - 1], b = sad[m], c = sad[m + 1], den = a - 2 * b + c;
      const double offset = den > 0 ? 0.5 * (a - c) / den : 0.0;
      // The patch is centred on the rounded left keypoint: carry its own rounding over.
      if (std::fabs(offset) <= 1.0) ur = ur0 + (m - 4) + offset + (kl.pt.x - ul);
    }
    const double disparity = kl.pt.x - ur;
    if (disparity < min_disparity || disparity > max_disparity) continue;
    left->u_right[i] = static_cast<float>(ur);
    left->depth[i] = static_cast<float>(bf / disparity);
  }
}

void depthFromImage(const cv::Mat& depth, double depth_factor, double bf, Features* features) {
  for (std::size_t i = 0; i < features->keypoints.size(); ++i) {
    const cv::Point2f& p = features->keypoints[i].pt;
    const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
    if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
    const double raw = depth.type() == CV_16U ? depth.at<std::uint16_t>(v, u) : depth.at<float>(v, u);
    const double d = raw / depth_factor;
    if (!(d > 0.05) || !std::isfinite(d)) continue;
    features->depth[i] = static_cast<float>(d);
    features->u_right[i] = static_cast<float>(p.x - bf / d);
  }
}

}  // namespace rvwo::estimator
