// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Dataset presets for rvwo-convert: each public dataset's camera as its authors published it, and
// the settings file (docs/rawlog.md) rvwo-replay takes with the converted rawlog.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace rvwo::apps {

struct DatasetPreset {
  std::string kind;                       // rvwo-convert's folder kind: "tum", "openloris"
  std::string name;                       // --preset: "fr1", ...
  std::string title;                      // what it is, for the settings' first lines
  std::string source;                     // where its figures were published
  std::string sensor;                     // Sensor: "rgbd", "stereo", "mono"
  int width = 0, height = 0;              // px [Camera.width, Camera.height]
  double fps = 0;                         // Hz [Camera.fps]
  double fx = 0, fy = 0, cx = 0, cy = 0;  // px [Camera1.fx ...]
  std::array<double, 5> radtan{};         // k1, k2, p1, p2, k3 (OpenCV) [Camera1.k1 ...]; 0: undistorted
  double depth_factor = 0;                // depth units a metre [RGBD.DepthMapFactor]
  // The camera in the robot's base frame, row by row [Camera.T_b_c]; the default: no robot base,
  // the base at the camera, x forward, y left, z up.
  std::array<double, 16> T_b_c{0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0, 1};
  // A Kannala-Brandt fisheye pair instead (OpenLORIS's T265): both cameras' k1..k4, the right
  // camera's intrinsics and its place in the left's frame, row by row [Camera2.*, Stereo.T_c1_c2].
  bool fisheye_pair = false;
  std::array<double, 4> kb_left{}, kb_right{};
  double fx2 = 0, fy2 = 0, cx2 = 0, cy2 = 0;
  std::array<double, 16> T_c1_c2{};
  std::string odometry_input;   // [Odometry.Input]; "": none written
  std::string still_to_supply;  // what the user must still give (printed by rvwo-convert)
};

// The presets of a folder kind.
std::vector<DatasetPreset> datasetPresets(const std::string& kind);
// The preset named `name` of `kind`; throws std::invalid_argument listing the names there are.
DatasetPreset datasetPreset(const std::string& kind, const std::string& name);
// The TUM preset a folder's name gives (rgbd_dataset_freiburgN_*), or "" when it gives none.
std::string tumPresetOfFolder(const std::filesystem::path& folder);
// An OpenLORIS-Scene sequence folder's own calibration, as its authors ship it beside the data:
// sensors.yaml (per camera: intrinsics [fx, cx, fy, cy], distortion coefficients, size, rate) and
// trans_matrix.yaml (parent_frame, child_frame, matrix: T_parent_child). The D435i colour camera
// (d400_color_optical_frame, radial-tangential), or with fisheye the T265 pair
// (t265_fisheye1_optical_frame and ..2.., Kannala-Brandt k1..k4); T_b_c through a chain from
// base_link. Throws std::runtime_error naming the file and what is missing.
DatasetPreset openLorisCalibration(const std::filesystem::path& folder, bool fisheye);
// Writes the settings file of `p`, whole or not at all.
void writePresetSettings(const DatasetPreset& p, const std::filesystem::path& file);

}  // namespace rvwo::apps
