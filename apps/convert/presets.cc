// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "convert/presets.h"

#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "rvwo/settings/settings.h"
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

// The transform from `from` to `to` through trans_matrix.yaml's entries (T_parent_child each),
// walked either way round; false when no chain joins them.
bool chain(const std::map<std::pair<std::string, std::string>, cv::Matx44d>& edges, const std::string& from,
           const std::string& to, cv::Matx44d* T) {
  std::map<std::string, cv::Matx44d> reached{{from, cv::Matx44d::eye()}};
  std::vector<std::string> todo{from};
  while (!todo.empty()) {
    const std::string f = todo.back();
    todo.pop_back();
    if (f == to) {
      *T = reached[f];
      return true;
    }
    for (const auto& [pc, M] : edges) {
      const bool forward = pc.first == f, backward = pc.second == f;
      const std::string next = forward ? pc.second : pc.first;
      if ((forward || backward) && !reached.count(next)) {
        reached[next] = reached[f] * (forward ? M : M.inv());
        todo.push_back(next);
      }
    }
  }
  return false;
}

}  // namespace

DatasetPreset openLorisCalibration(const std::filesystem::path& folder) {
  const std::string sensors_path = (folder / "sensors.yaml").string(),
                    trans_path = (folder / "trans_matrix.yaml").string();
  for (const std::string& path : {sensors_path, trans_path}) {  // what OpenCV's parser may not be given
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    if (in) checkYamlText(path, text.str());
  }
  cv::FileStorage sensors, trans;
  try {
    sensors.open(sensors_path, cv::FileStorage::READ);
    trans.open(trans_path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(folder.string() + ": sensors.yaml or trans_matrix.yaml is not readable YAML (" + e.msg +
                             ")");
  }
  if (!sensors.isOpened() || !trans.isOpened())
    throw std::runtime_error(folder.string() + ": no sensors.yaml and trans_matrix.yaml (the sequence's calibration)");
  const std::string camera = "d400_color_optical_frame";
  const cv::FileNode c = sensors[camera];
  cv::Mat intrinsics, distortion;
  if (!c.empty()) {
    c["intrinsics"] >> intrinsics;
    c["distortion_coefficients"] >> distortion;
  }
  if (intrinsics.total() != 4 || std::string(c["distortion_model"]) != "radial-tangential" || distortion.total() > 5)
    throw std::runtime_error(sensors_path + ": no " + camera +
                             " with intrinsics [fx, cx, fy, cy] and radial-tangential distortion_coefficients");
  std::map<std::pair<std::string, std::string>, cv::Matx44d> edges;
  for (const cv::FileNode& row : trans["trans_matrix"]) {
    cv::Mat M;
    row["matrix"] >> M;
    if (M.rows != 4 || M.cols != 4)
      throw std::runtime_error(trans_path + ": the matrix of " + std::string(row["parent_frame"]) + " to " +
                               std::string(row["child_frame"]) + " is not 4x4");
    M.convertTo(M, CV_64F);
    edges[{std::string(row["parent_frame"]), std::string(row["child_frame"])}] = cv::Matx44d(M);
  }
  cv::Matx44d T;
  if (!chain(edges, "base_link", camera, &T))
    throw std::runtime_error(trans_path + ": no chain of transforms from base_link to " + camera);
  DatasetPreset p;
  p.kind = "openloris";
  p.name = "(the sequence's own)";
  p.title = "OpenLORIS-Scene, RealSense D435i colour and aligned depth, on the robot's base_link";
  p.source = "the sequence's sensors.yaml and trans_matrix.yaml (OpenLORIS-Scene, Shi et al., ICRA 2020)";
  p.sensor = "rgbd";
  p.width = int(c["width"]);
  p.height = int(c["height"]);
  p.fps = double(c["fps"]);
  const cv::Mat k = intrinsics.reshape(1, 1);
  k.convertTo(intrinsics, CV_64F);
  p.fx = intrinsics.at<double>(0);
  p.cx = intrinsics.at<double>(1);
  p.fy = intrinsics.at<double>(2);
  p.cy = intrinsics.at<double>(3);
  distortion.reshape(1, 1).convertTo(distortion, CV_64F);
  for (int i = 0; i < static_cast<int>(distortion.total()); ++i) p.radtan[i] = distortion.at<double>(i);
  p.depth_factor = 1000;
  for (int i = 0; i < 16; ++i) p.T_b_c[i] = T(i / 4, i % 4);
  p.odometry_input = "pose";
  return p;
}

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
  o.precision(17);
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
  o << "Camera.T_b_c: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [";
  for (int i = 0; i < 16; ++i) o << (i ? ", " : "") << p.T_b_c[i];
  o << "]\n";
  if (!p.odometry_input.empty()) o << "Odometry.Input: \"" << p.odometry_input << "\"\n";
  o << "Semantics.LabelSet: \"voc21\"\n";
  writeWhole(file.string(), [&](const std::string& tmp) {
    std::ofstream out(tmp);
    if (!(out << o.str()) || !out.flush()) throw std::runtime_error(file.string() + ": cannot be written");
  });
}

}  // namespace rvwo::apps
