// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// ORB-SLAM3's image pyramid resampled where its keypoints' coordinates put each level
// (rvwo/orbslam3/pyramid.h), against upstream's cv::resize, on ramps whose value is the position.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "rvwo/orbslam3/pyramid.h"

namespace {

using rvwo::orbslam3::resamplePyramidLevel;

constexpr int kLevels = 8;
constexpr float kScale = 1.2f;  // ORBextractor.scaleFactor

// ORB-SLAM3's pyramid of `image` (ORBextractor::ComputePyramid): level n of cvRound(W / s^n) x
// cvRound(H / s^n), each level made from the one before, written in place into a bordered buffer.
// aligned: resamplePyramidLevel, else upstream's cv::resize.
std::vector<cv::Mat> pyramid(const cv::Mat& image, bool aligned, std::vector<float>* scales) {
  std::vector<cv::Mat> levels(kLevels);
  scales->assign(kLevels, 1.f);
  for (int n = 0; n < kLevels; ++n) {
    if (n > 0) (*scales)[n] = (*scales)[n - 1] * kScale;  // ORBextractor's mvScaleFactor
    const float inv = 1.f / (*scales)[n];
    const cv::Size sz(cvRound(image.cols * inv), cvRound(image.rows * inv));
    const int border = 19;  // EDGE_THRESHOLD
    cv::Mat buffer(sz.height + 2 * border, sz.width + 2 * border, image.type(), cv::Scalar(-1));
    levels[n] = buffer(cv::Rect(border, border, sz.width, sz.height));
    if (n == 0) {
      image.copyTo(levels[n]);
    } else if (aligned) {
      const uchar* before = levels[n].data;
      resamplePyramidLevel(levels[n - 1], levels[n], (*scales)[n] / (*scales)[n - 1]);
      EXPECT_EQ(levels[n].data, before) << "written in place, as ORB-SLAM3 needs";
      EXPECT_EQ(buffer.at<float>(0, 0), -1.f) << "the border left alone";
    } else {
      cv::resize(levels[n - 1], levels[n], sz, 0, 0, cv::INTER_LINEAR);
    }
  }
  return levels;
}

// Where, in image pixels, ORB-SLAM3 puts level n's pixels (i * s^n) against where their content
// is (a ramp's value along x is the position): the mean and the largest error over the level,
// away from the image's last 10 columns (beyond a finer level's edge its border repeats, and the
// repeat carries on to the coarser levels).
struct Offset {
  double mean, max_abs;
};
std::vector<Offset> offsetsAlongX(bool aligned) {
  const cv::Size size(640, 480);
  cv::Mat ramp(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) ramp.at<float>(y, x) = static_cast<float>(x);
  }
  std::vector<float> scales;
  const std::vector<cv::Mat> levels = pyramid(ramp, aligned, &scales);
  std::vector<Offset> out;
  for (int n = 0; n < kLevels; ++n) {
    double sum = 0, max_abs = 0;
    int count = 0;
    for (int y = 0; y < levels[n].rows; ++y) {
      for (int x = 0; x < levels[n].cols; ++x) {
        const double at = x * scales[n];  // where ORB-SLAM3 puts a keypoint found here
        if (at > size.width - 10) continue;
        const double e = at - levels[n].at<float>(y, x);
        sum += e;
        max_abs = std::max(max_abs, std::fabs(e));
        ++count;
      }
    }
    out.push_back({sum / count, max_abs});
  }
  return out;
}

TEST(OrbSlam3Pyramid, KeypointCoordinatesAreWhereTheLevelsContentIs) {
  const std::vector<Offset> aligned = offsetsAlongX(true);
  for (int n = 0; n < kLevels; ++n) {
    // Exact positions, float arithmetic (values up to 640).
    EXPECT_LT(std::fabs(aligned[n].mean), 1e-4) << "level " << n;
    EXPECT_LT(aligned[n].max_abs, 1e-3) << "level " << n;
  }
}

TEST(OrbSlam3Pyramid, UpstreamsResizeMisplacesCoarseKeypoints) {
  // What the aligned pyramid mends, and what the test above would see without it: cv::resize's
  // pixel i is at (i + 0.5) c_n - 0.5 of the image, c_n = 640 / cvRound(640 / 1.2^n), so a keypoint
  // put at i * 1.2^n is off by 0.5 (c_n - 1) on average plus i (1.2^n - c_n).
  const std::vector<Offset> upstream = offsetsAlongX(false);
  EXPECT_NEAR(upstream[0].mean, 0, 1e-9);
  for (int n = 1; n < kLevels; ++n) {
    const double s = std::pow(1.2, n), c = 640.0 / cvRound(640 / s);
    const int cols = cvRound(640 / s);
    double predicted = 0;
    int count = 0;
    for (int i = 0; i < cols; ++i) {
      if (i * s > 630) continue;
      predicted += i * s - ((i + 0.5) * c - 0.5);
      ++count;
    }
    EXPECT_NEAR(upstream[n].mean, predicted / count, 0.02) << "level " << n;
  }
  EXPECT_LT(upstream[7].mean, -0.5);  // 1.3 px up, less 0.2 % of the position (c_7 = 3.575 < 1.2^7)
}

TEST(OrbSlam3Pyramid, StereoDisparityAtEveryLevelIsTheImages) {
  // A right image shifted 10.3 px left of the left: matched at level n (the right level's pixel
  // holding the left's content, by the ramp's value) and scaled back by s^n, as ORB-SLAM3's
  // ComputeStereoMatches does, the disparity is 10.3 px at every level.
  const cv::Size size(640, 480);
  const double d = 10.3;
  cv::Mat left(size, CV_32F), right(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      left.at<float>(y, x) = static_cast<float>(x);
      right.at<float>(y, x) = static_cast<float>(x + d);
    }
  }
  for (bool aligned : {true, false}) {
    std::vector<float> scales;
    const std::vector<cv::Mat> l = pyramid(left, aligned, &scales), r = pyramid(right, aligned, &scales);
    double worst = 0;
    for (int n = 1; n < kLevels; ++n) {
      // Left pixel i at level n; the right level's value equal to it, where it lies at that level.
      const int i = l[n].cols / 2, y = l[n].rows / 2;
      const float value = l[n].at<float>(y, i);
      int j = 0;
      while (j + 2 < r[n].cols && r[n].at<float>(y, j + 1) <= value) ++j;
      const float r0 = r[n].at<float>(y, j), r1 = r[n].at<float>(y, j + 1);
      const double right_col = j + (value - r0) / (r1 - r0);
      const double disparity = scales[n] * (i - right_col);
      worst = std::max(worst, std::fabs(disparity - d));
      if (aligned) {
        EXPECT_NEAR(disparity, d, 1e-3) << "level " << n;
      }
    }
    // Upstream: the sizes' rounding scales disparities by up to 0.2 % (level 7: 10.32 px).
    if (!aligned) {
      EXPECT_GT(worst, 0.015);
    }
  }
}

TEST(OrbSlam3Pyramid, RefusesWhatItCannotWriteInPlace) {
  cv::Mat finer(48, 64, CV_8U, cv::Scalar(7)), level(40, 53, CV_8U), empty, wrong(40, 53, CV_32F);
  cv::Mat colour(48, 64, CV_8UC3), colour_level(40, 53, CV_8UC3);
  resamplePyramidLevel(finer, level, 1.2);
  EXPECT_EQ(cv::countNonZero(level != 7), 0) << "a flat image stays flat, edges repeated";
  EXPECT_THROW(resamplePyramidLevel(empty, level, 1.2), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(finer, empty, 1.2), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(finer, wrong, 1.2), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(colour, colour_level, 1.2), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(finer, level, 0), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(finer, level, std::numeric_limits<double>::infinity()), std::invalid_argument);
  EXPECT_THROW(resamplePyramidLevel(finer, level, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

}  // namespace
