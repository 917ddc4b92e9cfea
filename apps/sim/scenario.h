// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// A simulator scenario (docs/simulator.md): a cv::FileStorage YAML file with dotted keys, read
// into this struct; robot motion from a built-in loop or a real trajectory file.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "camera_effects.h"
#include "rvwo/edges/se2.h"

namespace rvwo::sim {

struct Interval {
  double t0, t1, value;
  bool contains(double t) const { return t >= t0 && t < t1; }
};

struct Scenario {
  std::string name;
  double duration = 60;           // s
  std::string camera = "stereo";  // stereo | rgbd | mono
  std::string lens = "pinhole";   // pinhole | fisheye
  double fps = 30;
  double focal = 0;             // px (Camera.Fx); 0: the lens's own, 400 pinhole, 286 fisheye
  double baseline = 0.12;       // m (Camera.Baseline): the stereo pair's
  std::string motion = "loop";  // loop | file
  double motion_speed = 1;      // a motion file played this many times as fast (Sequence.MotionSpeed)
  std::string motion_file;      // TUM rows; OpenLORIS "seq:" blocks; TUM Pioneer (tilted plane fitted away)
  int motion_block = 1;
  double loop_speed = 0.5;                       // m/s
  double room_x = 10, room_y = 8, room_h = 2.6;  // m (a motion file enlarges the room to fit)
  int furniture = 8;
  double odometry_rate = 100;  // Hz
  double radius_error = 0.01;  // relative: true left radius = nominal (1 + e), right (1 - e)
  double track_error = 0.02;   // relative: true track = nominal (1 + e)
  double wheel_noise = 0.005;  // rad/sqrt(rad) on each wheel's angle
  int ticks_per_revolution = 4096;
  int walkers = 0;                                           // crossing the room
  int escorts = 0;                                           // walking around the robot, in and out of its view
  double walker_speed = 1.0;                                 // m/s
  std::string walker_look = "people";                        // people (real, cut from photographs) | cylinders
  std::vector<Interval> slip, blackout, low_texture, bumps;  // bumps: value = height amplitude (m)
  std::vector<Interval> illumination;                        // value = gain from t0 on
  CameraEffects camera_effects;                              // Camera.*, Sequence.PixelNoise
  DepthEffects depth_effects;                                // Depth.* (RGB-D)
  std::string text;                                          // the file as read, written back beside the output
};

// Throws std::runtime_error "<file>: <key>: <what>".
Scenario loadScenario(const std::string& path);
// The same from a scenario's text; source names it in messages, and a relative motion file is
// found in folder.
Scenario parseScenario(const std::string& text, const std::string& source, const std::string& folder);
// The checks loadScenario applies, for a scenario changed afterwards (command-line overrides);
// source names it in the message.
void validateScenario(const Scenario& s, const std::string& source);

// The robot's planar motion, as a function of time from 0 to duration().
class Motion {
 public:
  explicit Motion(const Scenario& s);
  SE2 at(double t) const;
  double duration() const { return duration_; }
  // Bounding box of the path (for sizing the room).
  Eigen::Vector2d min() const { return min_; }
  Eigen::Vector2d max() const { return max_; }

 private:
  std::vector<double> t_;
  std::vector<SE2> pose_;
  double duration_ = 0;
  Eigen::Vector2d min_, max_;
};

}  // namespace rvwo::sim
