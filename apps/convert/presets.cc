// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "convert/presets.h"

#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "support/output.h"

namespace rvwo::apps {
namespace {

// TUM RGB-D benchmark (Sturm et al., IROS 2012), "Intrinsic Camera Calibration of the Kinect" on
// the dataset's page: the colour camera of each Freiburg rig, OpenCV's distortion model (d0..d4 =
// k1, k2, p1, p2, k3); depth registered to colour, 5000 units a metre; 640x480 at 30 Hz.
const char* kTumSource =
    "TUM RGB-D benchmark (Sturm et al., IROS 2012), \"Intrinsic Camera Calibration of the Kinect\", colour camera";
const char* kHandHeld =
    "no wheel odometry in the folder: replay with --mode vo; fr1 and fr3 are hand-held (6-DoF): RVWO's estimator "
    "is planar, so compare on them with --backend orbslam3";

DatasetPreset tum(const std::string& name, const std::string& title, double fx, double fy, double cx, double cy,
                  std::array<double, 5> radtan, const std::string& still) {
  DatasetPreset p;
  p.kind = "tum";
  p.name = name;
  p.title = title;
  p.source = kTumSource;
  p.sensor = "rgbd";
  p.width = 640;
  p.height = 480;
  p.fps = 30;
  p.fx = fx;
  p.fy = fy;
  p.cx = cx;
  p.cy = cy;
  p.radtan = radtan;
  p.depth_factor = 5000;
  p.still_to_supply = still;
  return p;
}

}  // namespace

std::vector<DatasetPreset> datasetPresets(const std::string& kind) {
  if (kind != "tum") return {};
  return {
      tum("fr1", "TUM RGB-D, Freiburg 1 (Kinect, hand-held)", 517.3, 516.5, 318.6, 255.3,
          {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}, kHandHeld),
      tum("fr2", "TUM RGB-D, Freiburg 2 (Kinect; the pioneer_* sequences on a Pioneer 3 robot)", 520.9, 521.0, 325.1,
          249.7, {0.2312, -0.7849, -0.0033, -0.0001, 0.9172},
          "no wheel odometry in the folder (the Pioneer sequences carry theirs in their bags): replay with --mode vo"),
      tum("fr3", "TUM RGB-D, Freiburg 3 (Asus Xtion; walking_* and sitting_* are the dynamic sequences)", 535.4, 539.2,
          320.1, 247.6, {0, 0, 0, 0, 0}, kHandHeld),
  };
}

DatasetPreset datasetPreset(const std::string& kind, const std::string& name) {
  std::string names;
  for (const DatasetPreset& p : datasetPresets(kind)) {
    if (p.name == name) return p;
    names += (names.empty() ? "" : ", ") + p.name;
  }
  throw std::invalid_argument("--preset " + name + ": " + kind + " has " +
                              (names.empty() ? std::string("no presets") : "the presets " + names));
}

std::string tumPresetOfFolder(const std::filesystem::path& folder) {
  std::smatch m;
  const std::string name = std::filesystem::absolute(folder).lexically_normal().filename().string().empty()
                               ? std::filesystem::absolute(folder).lexically_normal().parent_path().filename().string()
                               : std::filesystem::absolute(folder).lexically_normal().filename().string();
  return std::regex_search(name, m, std::regex("freiburg([123])_")) ? "fr" + m[1].str() : "";
}

void writePresetSettings(const DatasetPreset& p, const std::filesystem::path& file) {
  std::ostringstream o;
  o.precision(10);
  o << "%YAML:1.0\n"
    << "# written by rvwo-convert --preset " << p.name << ": " << p.title << "\n"
    << "# camera: " << p.source << "\n"
    << "Sensor: \"" << p.sensor << "\"\n"
    << "Camera.type: \"PinHole\"\n"
    << "Camera1.fx: " << p.fx << "\nCamera1.fy: " << p.fy << "\nCamera1.cx: " << p.cx << "\nCamera1.cy: " << p.cy
    << "\n";
  const char* keys[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (int i = 0; i < 5; ++i) o << "Camera1." << keys[i] << ": " << p.radtan[i] << "\n";
  o << "Camera.width: " << p.width << "\nCamera.height: " << p.height << "\nCamera.fps: " << p.fps << "\n";
  if (p.depth_factor > 0) o << "RGBD.DepthMapFactor: " << p.depth_factor << "\n";
  // No robot base in the dataset: the base is the camera's own place, x forward, z up.
  o << "# the base: the camera's own place, x forward, y left, z up (no robot base in the dataset)\n"
    << "Camera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
    << "   data: [0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0, 1]\n"
    << "Semantics.LabelSet: \"voc21\"\n";
  writeWhole(file.string(), [&](const std::string& tmp) {
    std::ofstream out(tmp);
    if (!(out << o.str()) || !out.flush()) throw std::runtime_error(file.string() + ": cannot be written");
  });
}

}  // namespace rvwo::apps
