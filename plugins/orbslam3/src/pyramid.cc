// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
#include "rvwo/orbslam3/pyramid.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <vector>

namespace rvwo::orbslam3 {
namespace {

// One axis: for output index i, the finer level's two neighbours of i * step and the weight of the
// second (0 beyond the last: the edge repeats).
struct Taps {
  std::vector<int> lo, hi;
  std::vector<float> w;
};
Taps taps(int out, int in, double step) {
  Taps t;
  t.lo.resize(out);
  t.hi.resize(out);
  t.w.resize(out);
  for (int i = 0; i < out; ++i) {
    const double x = i * step;
    const int x0 = static_cast<int>(std::floor(x));
    if (x0 >= in - 1) {
      t.lo[i] = t.hi[i] = in - 1;
      t.w[i] = 0;
    } else {
      t.lo[i] = x0;
      t.hi[i] = x0 + 1;
      t.w[i] = static_cast<float>(x - x0);
    }
  }
  return t;
}

template <typename T>
void resample(const cv::Mat& finer, cv::Mat& level, double step) {
  const Taps tx = taps(level.cols, finer.cols, step), ty = taps(level.rows, finer.rows, step);
  for (int y = 0; y < level.rows; ++y) {
    const T* r0 = finer.ptr<T>(ty.lo[y]);
    const T* r1 = finer.ptr<T>(ty.hi[y]);
    const float wy = ty.w[y];
    T* out = level.ptr<T>(y);
    for (int x = 0; x < level.cols; ++x) {
      const int a = tx.lo[x], b = tx.hi[x];
      const float wx = tx.w[x];
      const float top = r0[a] + wx * (static_cast<float>(r0[b]) - r0[a]);
      const float bottom = r1[a] + wx * (static_cast<float>(r1[b]) - r1[a]);
      out[x] = cv::saturate_cast<T>(top + wy * (bottom - top));  // 8-bit: rounded to the nearest
    }
  }
}

}  // namespace

void resamplePyramidLevel(const cv::Mat& finer, cv::Mat& level, double step) {
  if (finer.empty() || level.empty()) throw std::invalid_argument("resamplePyramidLevel: empty image");
  if (level.type() != finer.type()) throw std::invalid_argument("resamplePyramidLevel: level not of finer's type");
  if (!(step > 0) || !std::isfinite(step)) throw std::invalid_argument("resamplePyramidLevel: step must be > 0");
  // Bilinear at exact positions, written into the level in place. cv::warpAffine and cv::remap
  // would round the positions to 1/32 px: at level 7 a single pixel's then up to 0.07 px off.
  if (finer.type() == CV_8UC1) {
    resample<uchar>(finer, level, step);
  } else if (finer.type() == CV_32FC1) {
    resample<float>(finer, level, step);
  } else {
    throw std::invalid_argument("resamplePyramidLevel: 8-bit or float grey images only");
  }
}

}  // namespace rvwo::orbslam3
