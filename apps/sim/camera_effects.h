// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What a real camera does to the light a scene sends it, and what a structured-light depth camera
// does to depth (docs/simulator.md, "Camera effects"). Each effect has a scenario key; its "off"
// value gives back the perfect camera of earlier versions.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "scene.h"

namespace rvwo::sim {

struct CameraEffects {
  double exposure = 0.01;        // s, Camera.Exposure: motion blur over the open shutter; 0 none
  double row_delay = 0;          // s a row, Camera.RowDelay: rolling shutter; 0 global shutter
  double vignetting = 0.3;       // Camera.Vignetting: fraction of light lost in the image's corners; 0 none
  double auto_exposure = 0.4;    // s, Camera.AutoExposure: time constant of the gain's control; 0 gain 1
  double exposure_target = 118;  // grey levels, Camera.ExposureTarget: the image mean the control aims at
  double max_gain = 8;           // Camera.MaxGain: the control's range is [1 / max, max]
  double read_noise = 1.0;       // grey levels (std) at unit gain, Sequence.PixelNoise
  double shot_noise = 0.03;      // grey levels (variance per grey level of signal), Camera.ShotNoise; 0 none
  int jpeg_quality = 0;          // Camera.JpegQuality: 1-100 each image compressed so; 0 lossless
};

struct DepthEffects {
  double noise = 1.0;               // Depth.Noise: times Kinect's axial noise 0.0012 + 0.0019 (z - 0.4)^2 m; 0 none
  double max_incidence = 75;        // deg, Depth.MaxIncidence: no depth on surfaces seen more obliquely; 90 none
  double min_albedo = 50;           // grey levels, Depth.MinAlbedo: no depth on darker surfaces; 0 none
  double shift_x = 1, shift_y = 1;  // px, Depth.Misregistration [x, y]: depth off the colour image; 0 none
};

// Pixel noise from a counter-based hash of (seed, pixel): close to a unit Gaussian, the same bytes
// whatever the thread count.
float hashNoise(uint64_t seed, uint64_t pixel);

// Kinect's axial depth noise (m, standard deviation) at depth z (m), after Nguyen, Izadi and Lovell,
// "Modeling Kinect sensor noise for improved 3D reconstruction and tracking", 3DIMPVT 2012.
inline double kinectAxialNoise(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

// The image sensor: vignetting, gain, shot and read noise, 8-bit quantisation (saturating),
// optional JPEG; and the auto-exposure that sets the gain from the images it made.
class ImageSensor {
 public:
  ImageSensor(const CameraEffects& e, int width, int height, double frame_dt);
  // The 8-bit image of a radiance image (CV_64F, grey levels at unit gain); noise from the seed.
  cv::Mat expose(const cv::Mat& radiance, uint64_t noise_seed) const;
  // Auto-exposure. settle: the gain that brings this light to the target at once (a camera that
  // has settled before the first frame). meter: each image moves the gain towards the target mean
  // by the control's time constant. Neither does anything with the control off.
  void settle(const cv::Mat& radiance);
  void meter(const cv::Mat& image);
  double gain() const { return gain_; }
  // The fraction of light reaching pixel (x, y): 1 - vignetting rho^2, rho the distance from the
  // centre over the corner's.
  double vignette(int x, int y) const;

 private:
  CameraEffects e_;
  int width_, height_;
  double frame_dt_;
  double gain_ = 1;
};

// Depth as a structured-light camera gives it: none on surfaces seen more obliquely than
// max_incidence or darker than min_albedo, axial noise growing with depth, and registered to the
// colour image a little off (each colour pixel gets the depth measured shift_x, shift_y pixels
// away).
cv::Mat degradeDepth(const Render& r, const DepthEffects& e, uint64_t noise_seed);

}  // namespace rvwo::sim
