// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "convert/presets.h"

#include <algorithm>
#include <cctype>
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

// One camera of sensors.yaml: fx, fy, cx, cy (stored fx, cx, fy, cy), size, rate, coefficients.
struct LorisCamera {
  double fx, fy, cx, cy, fps;
  int width, height;
  std::vector<double> coefficients;
  std::string model;
};

LorisCamera lorisCamera(const cv::FileStorage& sensors, const std::string& path, const std::string& name) {
  const cv::FileNode c = sensors[name];
  cv::Mat intrinsics, distortion;
  if (!c.empty()) {
    c["intrinsics"] >> intrinsics;
    c["distortion_coefficients"] >> distortion;
  }
  if (intrinsics.total() != 4 || distortion.empty())
    throw std::runtime_error(path + ": no " + name + " with intrinsics [fx, cx, fy, cy] and distortion_coefficients");
  intrinsics.reshape(1, 1).convertTo(intrinsics, CV_64F);
  distortion.reshape(1, 1).convertTo(distortion, CV_64F);
  LorisCamera cam{intrinsics.at<double>(0),
                  intrinsics.at<double>(2),
                  intrinsics.at<double>(1),
                  intrinsics.at<double>(3),
                  double(c["fps"]),
                  int(c["width"]),
                  int(c["height"]),
                  std::vector<double>(distortion.begin<double>(), distortion.end<double>()),
                  std::string(c["distortion_model"])};
  return cam;
}

// sensors.yaml and trans_matrix.yaml, checked before OpenCV parses them; the transforms by frames.
struct LorisFiles {
  std::string sensors_path, trans_path;
  cv::FileStorage sensors;
  std::map<std::pair<std::string, std::string>, cv::Matx44d> edges;

  explicit LorisFiles(const std::filesystem::path& folder)
      : sensors_path((folder / "sensors.yaml").string()), trans_path((folder / "trans_matrix.yaml").string()) {
    for (const std::string& path : {sensors_path, trans_path}) {  // what OpenCV's parser may not be given
      std::ifstream in(path);
      std::stringstream text;
      text << in.rdbuf();
      if (in) checkYamlText(path, text.str());
    }
    cv::FileStorage trans;
    try {
      sensors.open(sensors_path, cv::FileStorage::READ);
      trans.open(trans_path, cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
      throw std::runtime_error(folder.string() + ": sensors.yaml or trans_matrix.yaml is not readable YAML (" + e.msg +
                               ")");
    }
    if (!sensors.isOpened() || !trans.isOpened())
      throw std::runtime_error(folder.string() +
                               ": no sensors.yaml and trans_matrix.yaml (the sequence's calibration)");
    for (const cv::FileNode& row : trans["trans_matrix"]) {
      cv::Mat M;
      row["matrix"] >> M;
      if (M.rows != 4 || M.cols != 4)
        throw std::runtime_error(trans_path + ": the matrix of " + std::string(row["parent_frame"]) + " to " +
                                 std::string(row["child_frame"]) + " is not 4x4");
      M.convertTo(M, CV_64F);
      edges[{std::string(row["parent_frame"]), std::string(row["child_frame"])}] = cv::Matx44d(M);
    }
  }

  std::array<double, 16> transform(const std::string& from, const std::string& to) const {
    cv::Matx44d T;
    if (!chain(edges, from, to, &T))
      throw std::runtime_error(trans_path + ": no chain of transforms from " + from + " to " + to);
    std::array<double, 16> out;
    for (int i = 0; i < 16; ++i) out[i] = T(i / 4, i % 4);
    return out;
  }
};

bool kannalaBrandt(const std::string& model) {
  std::string m;
  for (char c : model) m += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return m.find("equi") != std::string::npos || m.find("kannala") != std::string::npos ||
         m.find("fisheye") != std::string::npos || m.find("kb4") != std::string::npos;
}

}  // namespace

DatasetPreset openLorisCalibration(const std::filesystem::path& folder, bool fisheye) {
  const LorisFiles files(folder);
  const std::string left = fisheye ? "t265_fisheye1_optical_frame" : "d400_color_optical_frame";
  const LorisCamera c = lorisCamera(files.sensors, files.sensors_path, left);
  DatasetPreset p;
  p.kind = "openloris";
  p.name = "(the sequence's own)";
  p.source = "the sequence's sensors.yaml and trans_matrix.yaml (OpenLORIS-Scene, Shi et al., ICRA 2020)";
  p.width = c.width;
  p.height = c.height;
  p.fps = c.fps;
  p.fx = c.fx;
  p.fy = c.fy;
  p.cx = c.cx;
  p.cy = c.cy;
  p.T_b_c = files.transform("base_link", left);
  p.odometry_input = "pose";
  if (!fisheye) {
    if (c.model != "radial-tangential" || c.coefficients.size() > 5)
      throw std::runtime_error(files.sensors_path + ": " + left + ": distortion_model '" + c.model +
                               "', not radial-tangential with at most 5 coefficients");
    p.title = "OpenLORIS-Scene, RealSense D435i colour and aligned depth, on the robot's base_link";
    p.sensor = "rgbd";
    std::copy(c.coefficients.begin(), c.coefficients.end(), p.radtan.begin());
    p.depth_factor = 1000;
    return p;
  }
  const std::string right_name = "t265_fisheye2_optical_frame";
  const LorisCamera r = lorisCamera(files.sensors, files.sensors_path, right_name);
  for (const LorisCamera* cam : {&c, &r}) {
    if (!kannalaBrandt(cam->model) || cam->coefficients.size() < 4)
      throw std::runtime_error(files.sensors_path + ": a T265 camera's distortion_model '" + cam->model +
                               "', not an equidistant (Kannala-Brandt) one with k1..k4");
  }
  p.title = "OpenLORIS-Scene, RealSense T265 fisheye pair, on the robot's base_link";
  p.sensor = "stereo";
  p.fisheye_pair = true;
  std::copy_n(c.coefficients.begin(), 4, p.kb_left.begin());
  std::copy_n(r.coefficients.begin(), 4, p.kb_right.begin());
  p.fx2 = r.fx;
  p.fy2 = r.fy;
  p.cx2 = r.cx;
  p.cy2 = r.cy;
  p.T_c1_c2 = files.transform(left, right_name);
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
  std::filesystem::path dir = std::filesystem::absolute(folder).lexically_normal();
  if (dir.filename().empty()) dir = dir.parent_path();  // "folder/"
  const std::string name = dir.filename().string();
  std::smatch m;
  return std::regex_search(name, m, std::regex("freiburg([123])_")) ? "fr" + m[1].str() : "";
}

void writePresetSettings(const DatasetPreset& p, const std::filesystem::path& file) {
  std::ostringstream o;
  o.precision(17);
  o << "%YAML:1.0\n"
    << "# written by rvwo-convert --preset " << p.name << ": " << p.title << "\n"
    << "# camera: " << p.source << "\n"
    << "Sensor: \"" << p.sensor << "\"\n"
    << "Camera.type: \"" << (p.fisheye_pair ? "KannalaBrandt8" : "PinHole") << "\"\n"
    << "Camera1.fx: " << p.fx << "\nCamera1.fy: " << p.fy << "\nCamera1.cx: " << p.cx << "\nCamera1.cy: " << p.cy
    << "\n";
  auto matrix = [&](const char* key, const std::array<double, 16>& m) {
    o << key << ": !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [";
    for (int i = 0; i < 16; ++i) o << (i ? ", " : "") << m[i];
    o << "]\n";
  };
  if (p.fisheye_pair) {
    for (int i = 0; i < 4; ++i) o << "Camera1.k" << i + 1 << ": " << p.kb_left[i] << "\n";
    o << "Camera2.fx: " << p.fx2 << "\nCamera2.fy: " << p.fy2 << "\nCamera2.cx: " << p.cx2 << "\nCamera2.cy: " << p.cy2
      << "\n";
    for (int i = 0; i < 4; ++i) o << "Camera2.k" << i + 1 << ": " << p.kb_right[i] << "\n";
    matrix("Stereo.T_c1_c2", p.T_c1_c2);
  } else {
    const char* keys[5] = {"k1", "k2", "p1", "p2", "k3"};
    for (int i = 0; i < 5; ++i) o << "Camera1." << keys[i] << ": " << p.radtan[i] << "\n";
  }
  o << "Camera.width: " << p.width << "\nCamera.height: " << p.height << "\nCamera.fps: " << p.fps << "\n";
  if (p.depth_factor > 0) o << "RGBD.DepthMapFactor: " << p.depth_factor << "\n";
  matrix("Camera.T_b_c", p.T_b_c);
  if (!p.odometry_input.empty()) o << "Odometry.Input: \"" << p.odometry_input << "\"\n";
  o << "Semantics.LabelSet: \"voc21\"\n";
  writeWhole(file.string(), [&](const std::string& tmp) {
    std::ofstream out(tmp);
    if (!(out << o.str()) || !out.flush()) throw std::runtime_error(file.string() + ": cannot be written");
  });
}

}  // namespace rvwo::apps
