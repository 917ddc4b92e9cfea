// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// A frame's features: ORB keypoints (OpenCV) spread over the image on a grid, their descriptors,
// and for stereo or RGB-D each one's right-image coordinate u_R = u_L - bf / depth (ORB-SLAM's
// convention: the SE(2)-XYZ stereo edge measures (u_L, v, u_R)), or -1 where there is none.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

namespace rvwo::estimator {

struct FeatureParams {
  int features = 1000;               // per image
  double scale_factor = 1.2;         // pyramid scale between levels
  int levels = 6;                    // (Estimator.Levels: why six, in options.h)
  int fast_threshold = 12;           // grey levels
  int grid_cols = 8, grid_rows = 6;  // features are shared out over these cells by FAST response
};

struct Features {
  std::vector<cv::KeyPoint> keypoints;  // octave = pyramid level
  cv::Mat descriptors;                  // CV_8U, 32 bytes a row
  std::vector<float> u_right;           // px; -1: no stereo match or depth
  std::vector<float> depth;             // m along the optical axis; -1: none
  std::size_t size() const { return keypoints.size(); }

  // Keypoints within radius px of (u, v) whose level lies in [min_level, max_level] (grid lookup).
  std::vector<int> near(float u, float v, float radius, int min_level = 0, int max_level = 99) const;
  void buildGrid(int width, int height);

 private:
  static constexpr int kCell = 16;  // px
  int cols_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;
};

class FeatureExtractor {
 public:
  explicit FeatureExtractor(const FeatureParams& params);
  // image: 8-bit grey. Keypoints and descriptors only (u_right, depth set to -1).
  Features extract(const cv::Mat& image) const;
  const FeatureParams& params() const { return params_; }

 private:
  FeatureParams params_;
  cv::Ptr<cv::ORB> orb_;
};

// cv::ORB reports a level-n keypoint at its pixel p on level n times scale_factor^n, but builds
// level n from level n-1 by cv::resize to cvRound(W_0 / scale_factor^n) columns (and rows), whose
// pixel p holds level n-1 at (p + 0.5) W_{n-1} / W_n - 0.5: not the same place. In a 640 x 480
// image, -0.2 to 1.2 px off in x and -0.02 to 1.5 px in y on levels 1-5, varying across the image
// (a shift and a scale about its corner). Moves every keypoint of level > 0 to
// where its content lies in the image given to cv::ORB (image: that image's size; scale_factor:
// cv::ORB's). ORB-SLAM3's extractor has the same flaw (patches/orbslam3, 0015).
void placeOnTheirContent(const cv::Size& image, double scale_factor, std::vector<cv::KeyPoint>* keypoints);

// Rectified stereo, with no features in the right image (describing them cost a third of the
// replay's CPU and served only this): each left keypoint's 11x11 patch is slid along the same row
// of the right image over the disparity range; the column of smallest sum of absolute differences
// wins if no other column comes within 0.8 of it (repeated texture gets no depth) and it is not far
// worse than the frame's typical best (2.1 x the median: occlusions). Its column is then refined to
// sub-pixel by a patch (7x7 at level 0, wider for coarser keypoints) matched +-4 px along the row,
// through a parabola. Fills left.u_right and left.depth for disparities in [min_disparity,
// max_disparity].
void matchStereo(const cv::Mat& left_image, const cv::Mat& right_image, double bf, double min_disparity,
                 double max_disparity, Features* left);

// Sums of absolute differences of the (2h+1)^2 patch centred at (x, y) in left with the patches
// centred at (xr + p, y) in right, for p in [0, n), into sads[0, n). Both 8-bit grey; every patch
// must lie inside its image. Sixteen columns at once with SIMD where OpenCV has it (SSE2, NEON),
// scalar otherwise: the same sums either way.
void patchSads(const cv::Mat& left, const cv::Mat& right, int x, int y, int xr, int n, int h, std::uint32_t* sads);

// RGB-D: depth at each keypoint (metres = raw / depth_factor; 0 or invalid = none), u_R from bf.
// depth: CV_16U or CV_32F, the image's size.
void depthFromImage(const cv::Mat& depth, double depth_factor, double bf, Features* features);

int hammingDistance(const cv::Mat& a, const cv::Mat& b);              // 32-byte rows
int hammingDistance(const unsigned char* a, const unsigned char* b);  // 32 bytes each

// The closest and the second-closest of the descriptor distances offered, for the ratio test.
// best starts at the largest distance that may win (e.g. 61: only distances <= 60 are taken).
struct BestTwo {
  int best = 256, second = 256, index = -1;
  void offer(int distance, int i) {
    if (distance < best) {
      second = best;
      best = distance;
      index = i;
    } else if (distance < second) {
      second = distance;
    }
  }
  // As offer, but a tie for the best goes to the lower i: the result is the same in any order of
  // offers, and equal to offer's in ascending order of i.
  void offerAnyOrder(int distance, int i) {
    if (distance == best && index >= 0 && i < index) {
      second = best;
      index = i;
    } else {
      offer(distance, i);
    }
  }
};

}  // namespace rvwo::estimator
