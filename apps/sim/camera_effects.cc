// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "camera_effects.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

namespace rvwo::sim {

// splitmix64 of (seed, pixel); one hash gives four 16-bit uniforms, whose sum, scaled to unit
// variance, is close to Gaussian (Irwin-Hall).
float hashNoise(uint64_t seed, uint64_t pixel) {
  uint64_t h = seed * 0x9E3779B97F4A7C15ull + pixel * 0xBF58476D1CE4E5B9ull + 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
  h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
  h ^= h >> 31;
  const float sum = static_cast<float>((h & 0xFFFF) + ((h >> 16) & 0xFFFF) + ((h >> 32) & 0xFFFF) + (h >> 48));
  return (sum * (1.0f / 65536.0f) - 2.0f) * 1.7320508f;  // variance of the sum of four U(0,1): 1/3
}

ImageSensor::ImageSensor(const CameraEffects& e, int width, int height, double frame_dt)
    : e_(e), width_(width), height_(height), frame_dt_(frame_dt) {}

double ImageSensor::vignette(int x, int y) const {
  const double cx = 0.5 * (width_ - 1), cy = 0.5 * (height_ - 1);
  const double rho2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (cx * cx + cy * cy);
  return 1 - e_.vignetting * rho2;
}

cv::Mat ImageSensor::expose(const cv::Mat& radiance, uint64_t noise_seed) const {
  cv::Mat image(radiance.size(), CV_8U);
  cv::parallel_for_(cv::Range(0, radiance.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const double* rad = radiance.ptr<double>(y);
      uint8_t* img = image.ptr<uint8_t>(y);
      for (int x = 0; x < radiance.cols; ++x) {
        // The light collected, then noise in proportion to it (shot) and without it (read); the
        // gain amplifies both. With every effect off each step is exact (x 1, sqrt(r^2) = r), so the
        // perfect camera's bytes come out.
        const double e = rad[x] * vignette(x, y);
        const double sigma = std::sqrt(e_.read_noise * e_.read_noise + e_.shot_noise * std::max(e, 0.0));
        const double value = e + sigma * hashNoise(noise_seed, static_cast<uint64_t>(y) * radiance.cols + x);
        img[x] = cv::saturate_cast<uint8_t>(gain_ * value);
      }
    }
  });
  if (e_.jpeg_quality > 0) {
    std::vector<uint8_t> bytes;
    cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, e_.jpeg_quality});
    image = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  }
  return image;
}

void ImageSensor::settle(const cv::Mat& radiance) {
  if (e_.auto_exposure <= 0) return;
  double light = 0;  // the mean light collected, before the gain
  for (int y = 0; y < radiance.rows; ++y) {
    for (int x = 0; x < radiance.cols; ++x) light += radiance.at<double>(y, x) * vignette(x, y);
  }
  light /= static_cast<double>(radiance.total());
  gain_ = std::clamp(e_.exposure_target / std::max(light, 1.0), 1 / e_.max_gain, e_.max_gain);
}

void ImageSensor::meter(const cv::Mat& image) {
  if (e_.auto_exposure <= 0) return;
  // A first-order control on the logarithm of the gain, as cameras' exposure loops behave: the
  // image's mean (saturated as it is) against the target.
  const double mean = cv::mean(image)[0];
  const double step = 1 - std::exp(-frame_dt_ / e_.auto_exposure);
  gain_ = std::clamp(gain_ * std::pow(e_.exposure_target / std::max(mean, 1.0), step), 1 / e_.max_gain, e_.max_gain);
}

cv::Mat degradeDepth(const Render& r, const DepthEffects& e, uint64_t noise_seed) {
  cv::Mat out(r.depth.size(), CV_32F, cv::Scalar(0));
  const int dx = static_cast<int>(std::lround(e.shift_x)), dy = static_cast<int>(std::lround(e.shift_y));
  const double min_cos = std::cos(e.max_incidence * M_PI / 180);
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      float* dst = out.ptr<float>(y);
      const int sy = y + dy;
      if (sy < 0 || sy >= out.rows) continue;
      for (int x = 0; x < out.cols; ++x) {
        const int sx = x + dx;
        if (sx < 0 || sx >= out.cols) continue;
        const double z = r.depth.at<float>(sy, sx);
        if (z <= 0) continue;
        if (e.max_incidence < 90 && r.incidence.at<float>(sy, sx) < min_cos) continue;
        if (r.albedo.at<float>(sy, sx) < e.min_albedo) continue;
        const double noise = e.noise != 0 ? e.noise * kinectAxialNoise(z) *
                                                hashNoise(noise_seed, static_cast<uint64_t>(y) * out.cols + x)
                                          : 0.0;
        dst[x] = static_cast<float>(std::max(z + noise, 0.0));
      }
    }
  });
  return out;
}

}  // namespace rvwo::sim
