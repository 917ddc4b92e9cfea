// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "randomise.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "scenario.h"

namespace rvwo::sim {

namespace fs = std::filesystem;

std::string motionFolder() {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("RVWO_SCENARIO_DIR"); env && *env) candidates.push_back(fs::path(env) / "motion");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path().parent_path() / "share" / "rvwo" / "scenarios" / "motion");
  candidates.push_back(fs::path(RVWO_SOURCE_SCENARIO_DIR) / "motion");
  std::string looked;
  for (const fs::path& dir : candidates) {
    if (fs::is_directory(dir, ec)) return fs::canonical(dir, ec).string();
    looked += (looked.empty() ? "" : ", ") + dir.string();
  }
  throw std::runtime_error("the bundled motions (scenarios/motion) are in none of: " + looked +
                           " (set RVWO_SCENARIO_DIR to the scenarios folder)");
}

namespace {

// Draws from one generator, in the order of the calls (the text below reads them in that order).
class Draw {
 public:
  explicit Draw(unsigned seed) : rng_(seed * 2654435761u + 12345u) {}
  double real(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  bool chance(double p) { return real(0, 1) < p; }

 private:
  std::mt19937_64 rng_;
};

// Events in disjoint slots of [2 s, duration - 2 s): slip, blackout, low texture and bumps each
// take a slot of their own, so that the sequence stays one a wheeled robot could meet.
struct Slots {
  double from, to;
  std::vector<std::pair<double, double>> taken;
  // An interval of the given length, or none when the draw overlaps one taken.
  bool place(Draw& d, double length, double* t0) {
    if (to - from < length + 1) return false;
    const double a = d.real(from, to - length);
    for (const auto& [b0, b1] : taken)
      if (a < b1 + 1 && a + length + 1 > b0) return false;
    taken.emplace_back(a, a + length);
    *t0 = a;
    return true;
  }
};

// v's groups of `per` numbers in the order of their first (a time).
std::string list(std::vector<double> v, std::size_t per) {
  std::vector<std::vector<double>> groups;
  for (std::size_t i = 0; i + per <= v.size(); i += per) groups.emplace_back(v.begin() + i, v.begin() + i + per);
  std::sort(groups.begin(), groups.end());
  v.clear();
  for (const auto& g : groups) v.insert(v.end(), g.begin(), g.end());
  std::ostringstream o;
  o << std::fixed << std::setprecision(3) << "[";
  for (std::size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << v[i];
  return o.str() + "]";
}

}  // namespace

std::string randomScenario(unsigned seed, const std::string& camera, const std::string& lens, double duration,
                           const std::string& motion_folder) {
  std::vector<std::string> motions;
  for (const auto& e : fs::directory_iterator(motion_folder))
    if (e.path().extension() == ".txt") motions.push_back(e.path().string());
  if (motions.empty()) throw std::runtime_error(motion_folder + ": no motion files (*.txt)");
  std::sort(motions.begin(), motions.end());
  Draw d(seed);
  Scenario s;
  s.camera = camera;
  s.motion = "file";
  s.motion_file = motions[static_cast<std::size_t>(d.integer(0, static_cast<int>(motions.size()) - 1))];
  s.motion_speed = d.real(0.7, 1.3);
  s.duration = 1e9;  // the whole motion, then cut
  s.duration = std::min(duration, Motion(s).duration());
  const bool drawn_fisheye = camera != "rgbd" && d.chance(0.3),
             fisheye = lens.empty() ? drawn_fisheye : lens == "fisheye";
  std::ostringstream o;
  o << std::setprecision(4) << "%YAML:1.0\n# rvwo-sim --randomise --seed " << seed << " --camera " << camera << "\n"
    << "Sequence.Duration: " << s.duration << "\nSequence.Camera: \"" << camera << "\"\nSequence.Lens: \""
    << (fisheye ? "fisheye" : "pinhole") << "\"\nSequence.Motion: \"file\"\nSequence.MotionFile: \"" << s.motion_file
    << "\"\nSequence.MotionSpeed: " << s.motion_speed << "\n";
  // The camera: a focal length for a 640-pixel image's 60 to 90 degrees (fisheye: T265-like
  // lenses), a baseline from a RealSense's to a ZED's, and its exposure and noise.
  o << "Camera.Fx: " << (fisheye ? d.real(260, 310) : d.real(320, 560)) << "\nCamera.Baseline: " << d.real(0.05, 0.15)
    << "\nCamera.Exposure: " << d.real(0.003, std::min(0.02, 1 / 30.0)) << "\nCamera.Vignetting: " << d.real(0.1, 0.45)
    << "\nSequence.PixelNoise: " << d.real(0.5, 2.0) << "\n";
  // The room, the wheels' calibration and noise, the people.
  o << "Room.SizeX: " << d.real(8, 14) << "\nRoom.SizeY: " << d.real(6, 12) << "\nRoom.Height: " << d.real(2.4, 3.2)
    << "\nRoom.Furniture: " << d.integer(3, 14) << "\nOdometry.RadiusError: " << d.real(-0.02, 0.02)
    << "\nOdometry.TrackError: " << d.real(-0.04, 0.04) << "\nOdometry.NoiseWheel: " << d.real(0.002, 0.008)
    << "\nWalkers.Count: " << d.integer(0, 4) << "\nWalkers.Escorts: " << d.integer(0, 2)
    << "\nWalkers.Speed: " << d.real(0.7, 1.3) << "\n";
  // Events, each kind 0 to 2 times, in slots of their own, written in time order (the light's
  // changes must be: the last one begun holds).
  Slots slots{2.0, s.duration - 2.0, {}};
  std::vector<double> slip, blackout, low, bumps, light;
  double t0 = 0;
  for (int n = d.integer(0, 2); n > 0; --n) {
    const double length = d.real(1.0, 2.5);
    if (slots.place(d, length, &t0)) slip.insert(slip.end(), {t0, t0 + length});
  }
  for (int n = d.integer(0, 1); n > 0; --n) {
    const double length = d.real(1.0, 3.0);
    if (slots.place(d, length, &t0)) blackout.insert(blackout.end(), {t0, t0 + length});
  }
  for (int n = d.integer(0, 1); n > 0; --n) {
    const double length = d.real(3.0, 8.0), contrast = d.real(0.3, 0.7);
    if (slots.place(d, length, &t0)) low.insert(low.end(), {t0, t0 + length, contrast});
  }
  for (int n = d.integer(0, 1); n > 0; --n) {
    const double length = d.real(3.0, 10.0), amplitude = d.real(0.005, 0.015);
    if (slots.place(d, length, &t0)) bumps.insert(bumps.end(), {t0, t0 + length, amplitude});
  }
  for (int n = d.integer(0, 3); n > 0; --n) {
    const double t = d.real(0, s.duration), gain = d.real(0.6, 1.4);  // (in this order on every compiler)
    light.insert(light.end(), {t, gain});
  }
  if (!slip.empty()) o << "Events.Slip: " << list(slip, 2) << "\n";
  if (!blackout.empty()) o << "Events.Blackout: " << list(blackout, 2) << "\n";
  if (!low.empty()) o << "Events.LowTexture: " << list(low, 3) << "\n";
  if (!bumps.empty()) o << "Events.Bumps: " << list(bumps, 3) << "\n";
  if (!light.empty()) o << "Events.Illumination: " << list(light, 2) << "\n";
  return o.str();
}

}  // namespace rvwo::sim
