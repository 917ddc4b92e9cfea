// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The text files of a dataset folder, as rvwo-convert reads them: "t path" image lists (TUM's
// rgb.txt, OpenLORIS's color.txt, ...), OpenLORIS's odom.txt and the generic odometry.csv. Every
// line is checked: a malformed line, a missing image, or a time that does not increase is a
// std::runtime_error naming the file and the line (also fuzzed: tests/fuzz/convert_fuzz.cc).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rvwo::apps {

struct Entry {
  double t;
  std::string path;   // absolute
  std::string where;  // "file:line", for messages
};

struct Odometry {
  double t = 0, x = 0, y = 0, theta = 0;  // s; the odometry's pose, m and rad
  bool pose = true, angles = false, twist = false;
  std::int32_t ticks_left = 0, ticks_right = 0;  // wheel angles as encoder ticks, kTicksPerRevolution a turn
  double v = 0, omega = 0;                       // forward speed (m/s) and turn rate (rad/s)
};

// Encoder ticks a wheel turn, for wheel angles given in radians (rvwo-bag writes the same into the
// settings as Odometry.TicksPerRevolution): a power of two, so that ticks scale angles exactly.
constexpr double kTicksPerRevolution = 65536;

// Throws std::runtime_error("where: what").
[[noreturn]] void fail(const std::string& where, const std::string& what);

// "t path" lists: '#' comments; paths relative to the folder, each an existing file; times
// increasing. A missing file: an error when required, else no entries.
std::vector<Entry> readList(const std::filesystem::path& folder, const std::string& name, bool required = true);

// odom.txt (OpenLORIS: t x y z qx qy qz qw [twist]): the planar pose.
std::vector<Odometry> readOpenLorisOdometry(const std::filesystem::path& file);

// odometry.csv: "t,x,y,theta" rows; a header line may name its columns instead, each among t, x,
// y, theta (pose), left_angle, right_angle (rad: ticks), v, omega (m/s, rad/s), in any order.
std::vector<Odometry> readOdometryCsv(const std::filesystem::path& file);

}  // namespace rvwo::apps
