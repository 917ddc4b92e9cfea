// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The simulated camera's effects against their models: shot and read noise (sample variance),
// vignetting, the auto-exposure's lag (its time constant), motion blur against the exposure
// integrated by brute force (many renders over the open shutter), a rolling shutter's rows, and
// the depth camera's noise, holes and misregistration.
#include "sim/camera_effects.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sim/scene.h"

namespace rvwo::sim {
namespace {

constexpr int kW = 640, kH = 480;

CameraEffects noEffects() {
  CameraEffects e;
  e.exposure = 0;
  e.vignetting = 0;
  e.auto_exposure = 0;
  e.shot_noise = 0;
  e.read_noise = 0;
  return e;
}

cv::Mat flat(double level) { return cv::Mat(kH, kW, CV_64F, cv::Scalar(level)); }

TEST(CameraEffects, NoiseHasTheShotAndReadVariance) {
  CameraEffects e = noEffects();
  e.read_noise = 1.5;
  e.shot_noise = 0.05;
  const ImageSensor sensor(e, kW, kH, 1 / 30.0);
  for (const double level : {20.0, 100.0, 200.0}) {
    cv::Mat image, mean, stddev;
    sensor.expose(flat(level), 7).convertTo(image, CV_64F);
    cv::meanStdDev(image, mean, stddev);
    // Quantisation to whole grey levels adds 1/12.
    const double expected = e.read_noise * e.read_noise + e.shot_noise * level + 1.0 / 12;
    const double variance = stddev.at<double>(0) * stddev.at<double>(0);
    EXPECT_NEAR(variance / expected, 1.0, 0.02) << "at " << level << " grey levels: " << variance;
    EXPECT_NEAR(mean.at<double>(0), level, 0.02);
  }
  // Without shot noise the variance does not grow with the light.
  e.shot_noise = 0;
  cv::Mat bright, dark, m, s_bright, s_dark;
  ImageSensor(e, kW, kH, 1 / 30.0).expose(flat(200), 3).convertTo(bright, CV_64F);
  ImageSensor(e, kW, kH, 1 / 30.0).expose(flat(20), 3).convertTo(dark, CV_64F);
  cv::meanStdDev(bright, m, s_bright);
  cv::meanStdDev(dark, m, s_dark);
  EXPECT_NEAR(s_bright.at<double>(0), s_dark.at<double>(0), 1e-9);
}

TEST(CameraEffects, VignettingDarkensTheCorners) {
  CameraEffects e = noEffects();
  e.vignetting = 0.3;
  const ImageSensor sensor(e, kW, kH, 1 / 30.0);
  const cv::Mat image = sensor.expose(flat(200), 1);
  EXPECT_NEAR(image.at<uint8_t>(kH / 2, kW / 2), 200, 1);
  EXPECT_NEAR(image.at<uint8_t>(0, 0), 200 * 0.7, 1);
  EXPECT_NEAR(image.at<uint8_t>(kH - 1, kW - 1), 200 * 0.7, 1);
  EXPECT_NEAR(image.at<uint8_t>(kH / 2, 0), 200 * (1 - 0.3 * 0.64), 1);  // (319.5 / 399.5)^2 of the corner's
}

TEST(CameraEffects, AutoExposureFollowsWithItsTimeConstant) {
  CameraEffects e = noEffects();
  e.auto_exposure = 0.4;
  const double dt = 1 / 30.0;
  ImageSensor sensor(e, kW, kH, dt);
  sensor.settle(flat(100));
  EXPECT_NEAR(sensor.gain(), e.exposure_target / 100, 1e-12);
  // The light halves: the gain's logarithm closes the gap by exp(-t / tau), up to whole grey levels.
  const double start = std::log(e.exposure_target / 50 / sensor.gain());
  for (int k = 1; k <= 24; ++k) {
    sensor.meter(sensor.expose(flat(50), k));
    const double left = std::log(e.exposure_target / 50 / sensor.gain());
    EXPECT_NEAR(left / start, std::exp(-k * dt / e.auto_exposure), 0.02) << "frame " << k;
  }
  // Darkness: the gain stops at its limit; a lens uncovered then is saturated until it recovers.
  for (int k = 0; k < 90; ++k) sensor.meter(sensor.expose(flat(2), k));
  EXPECT_DOUBLE_EQ(sensor.gain(), e.max_gain);
  EXPECT_GT(cv::mean(sensor.expose(flat(100), 1))[0], 254.99);
  // Off: the gain stays 1.
  ImageSensor fixed(noEffects(), kW, kH, dt);
  fixed.settle(flat(10));
  fixed.meter(fixed.expose(flat(10), 1));
  EXPECT_EQ(fixed.gain(), 1.0);
}

TEST(CameraEffects, JpegIsLossyOnlyWhenAsked) {
  CameraEffects e = noEffects();
  e.read_noise = 3;
  const cv::Mat lossless = ImageSensor(e, kW, kH, 1 / 30.0).expose(flat(120), 5);
  e.jpeg_quality = 20;
  const cv::Mat jpeg = ImageSensor(e, kW, kH, 1 / 30.0).expose(flat(120), 5);
  cv::Mat diff;
  cv::absdiff(lossless, jpeg, diff);
  EXPECT_GT(cv::mean(diff)[0], 1.0);         // the noise is mostly gone
  EXPECT_NEAR(cv::mean(jpeg)[0], 120, 3.0);  // a DC step at quality 20: 5 grey levels
}

// A level camera at (0.3, -0.2, 1.2) turning at rate rad/s about the vertical from yaw 0.3 at t =
// 0, and a walker crossing its view at 1.5 m/s.
struct Turning {
  Scene scene{10, 8, 2.6, 3, 6};
  PinholeCamera camera{400, 400, 319.5, 239.5};
  cv::Mat rays = Scene::rayTable(camera, kW, kH);
  View view;
  explicit Turning(double rate, double row_delay = 0) {
    Walker w;
    w.a = Eigen::Vector2d(2.5, -3);
    w.b = Eigen::Vector2d(2.5, 3);
    w.speed = 1.5;
    w.phase = 3.6;  // at y = 0.6 at t = 0, in front of the camera
    w.t_on = -1;    // and there before the shutter opens
    scene.addWalker(w);
    view.T_w_c = [rate](double t) {
      const double yaw = 0.3 + rate * t;
      Eigen::Matrix3d R_w_c;
      R_w_c << -std::sin(yaw), 0, std::cos(yaw), std::cos(yaw), 0, std::sin(yaw), 0, -1, 0;
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = R_w_c;
      T.translation() << 0.3, -0.2, 1.2;
      return T;
    };
    view.robot = [](double) { return Eigen::Vector3d(0.05, -0.2, 0.3); };
    view.row_delay = row_delay;
  }
};

double meanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  return cv::mean(d)[0];
}

TEST(CameraEffects, MotionBlurIsTheExposureIntegrated) {
  Turning world(1.5);
  const double exposure = 0.02;  // 12 px of blur from the turn, 7 px more on the walker
  const RenderOptions o;
  const Render sharp = world.scene.render(world.view, world.rays, o);
  ASSERT_GT(cv::countNonZero(sharp.labels), 5000) << "the walker is in view";
  const cv::Mat blurred = world.scene.motionBlur(sharp, world.view, world.rays, world.camera, exposure);
  // The truth: the light averaged over renders spread across the open shutter.
  cv::Mat integrated = flat(0);
  const int renders = 48;
  for (int k = 0; k < renders; ++k) {
    View at = world.view;
    at.t = (k + 0.5) / renders * exposure - 0.5 * exposure;
    integrated += world.scene.render(at, world.rays, o).radiance / renders;
  }
  const double sharp_error = meanAbsDiff(sharp.radiance, integrated);
  const double blur_error = meanAbsDiff(blurred, integrated);
  std::cout << "mean |sharp - integrated| " << sharp_error << ", |blurred - integrated| " << blur_error << "\n";
  EXPECT_GT(sharp_error, 3.0);
  EXPECT_LT(blur_error, 0.12 * sharp_error);
  // The walker alone: its own motion counts too.
  cv::Mat walker_mask = sharp.labels > 0;
  cv::erode(walker_mask, walker_mask, cv::Mat(), cv::Point(-1, -1), 10);
  cv::Mat d_sharp, d_blur;
  cv::absdiff(sharp.radiance, integrated, d_sharp);
  cv::absdiff(blurred, integrated, d_blur);
  EXPECT_LT(cv::mean(d_blur, walker_mask)[0], 0.25 * cv::mean(d_sharp, walker_mask)[0]);
  // Shutter closed: no blur.
  EXPECT_EQ(meanAbsDiff(world.scene.motionBlur(sharp, world.view, world.rays, world.camera, 0), sharp.radiance), 0);
}

TEST(CameraEffects, RollingShutterReadsEachRowAtItsTime) {
  const double row_delay = 30e-6;  // 14 ms from the first row to the last
  Turning rolling(1.5, row_delay), global(1.5);
  const Render r = rolling.scene.render(rolling.view, rolling.rays, RenderOptions());
  for (const int y : {0, 100, 239, 400, 479}) {
    View at = global.view;
    at.t = rolling.view.rowTime(y, kH);
    const Render g = global.scene.render(at, global.rays, RenderOptions());
    EXPECT_EQ(meanAbsDiff(r.radiance.row(y), g.radiance.row(y)), 0) << "row " << y;
  }
  EXPECT_NEAR(rolling.view.rowTime(0, kH), -0.5 * (kH - 1) * row_delay, 1e-15);
  // And it differs from a global shutter's image away from the middle rows.
  const Render g = global.scene.render(global.view, global.rays, RenderOptions());
  EXPECT_GT(meanAbsDiff(r.radiance.row(0), g.radiance.row(0)), 1.0);
}

TEST(CameraEffects, DepthHasKinectNoiseHolesAndAnOffset) {
  Turning world(0);
  const Render r = world.scene.render(world.view, world.rays, RenderOptions());
  DepthEffects e;
  e.noise = 1;
  e.max_incidence = 90;
  e.min_albedo = 0;
  e.shift_x = e.shift_y = 0;
  // Noise: the error over depth bands against the model's standard deviation.
  const cv::Mat noisy = degradeDepth(r, e, 11);
  for (const double z : {2.0, 3.5, 5.0}) {
    double sum = 0, sum2 = 0, model = 0;
    int n = 0;
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        const double truth = r.depth.at<float>(y, x);
        if (std::fabs(truth - z) > 0.25) continue;
        const double err = noisy.at<float>(y, x) - truth;
        sum += err;
        sum2 += err * err;
        model += kinectAxialNoise(truth) * kinectAxialNoise(truth);
        ++n;
      }
    }
    ASSERT_GT(n, 3000) << "depth band " << z;
    EXPECT_NEAR(std::sqrt(sum2 / n) / std::sqrt(model / n), 1.0, 0.05) << "depth band " << z;
    EXPECT_LT(std::fabs(sum / n), 3 * std::sqrt(model / n / n));  // unbiased
  }
  // Holes: on surfaces seen more obliquely than the limit, and on dark ones; nowhere else.
  e.noise = 0;
  e.max_incidence = 60;
  e.min_albedo = 80;
  const cv::Mat holes = degradeDepth(r, e, 11);
  int oblique = 0, dark = 0, wrong = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const bool should = r.incidence.at<float>(y, x) < std::cos(M_PI / 3) || r.albedo.at<float>(y, x) < 80;
      oblique += r.incidence.at<float>(y, x) < std::cos(M_PI / 3);
      dark += r.albedo.at<float>(y, x) < 80;
      wrong += should != (holes.at<float>(y, x) == 0);
    }
  }
  EXPECT_GT(oblique, 1000);
  EXPECT_GT(dark, 1000);
  EXPECT_EQ(wrong, 0);
  // Misregistration: each pixel gets the depth measured 2 px right and 1 px down.
  e.max_incidence = 90;
  e.min_albedo = 0;
  e.shift_x = 2;
  e.shift_y = 1;
  const cv::Mat shifted = degradeDepth(r, e, 11);
  EXPECT_EQ(meanAbsDiff(shifted(cv::Rect(0, 0, kW - 2, kH - 1)), r.depth(cv::Rect(2, 1, kW - 2, kH - 1))), 0);
  EXPECT_EQ(cv::countNonZero(shifted.col(kW - 1)), 0);
}

}  // namespace
}  // namespace rvwo::sim
