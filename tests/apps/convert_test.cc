// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// rvwo-convert on small folders the test writes (TUM RGB-D, OpenLORIS-Scene, generic): the
// rawlogs read back with the right observations, images load from where they are, and a
// malformed folder gets one error naming the file and line.
#include <gtest/gtest.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <sys/wait.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "../common/temp.h"
#include "support/rawlog.h"

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;

fs::path fresh(const std::string& name) {
  const fs::path d = rvwo::test::scratch(name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void image(const fs::path& p, int value, int type = CV_8UC3) {
  fs::create_directories(p.parent_path());
  cv::imwrite(p.string(), cv::Mat(24, 32, type, cv::Scalar::all(value)));
}

// Runs rvwo-convert; returns its exit status and puts its stderr in *err.
int convert(const std::string& args, std::string* err = nullptr) {
  const fs::path e = rvwo::test::scratch("rvwo_convert_err.txt");
  const int rc = std::system((std::string(RVWO_CONVERT) + " " + args + " > /dev/null 2> " + e.string()).c_str());
  if (err) {
    std::stringstream s;
    s << std::ifstream(e).rdbuf();
    *err = s.str();
  }
  return rc;
}

std::vector<mrpt::obs::CObservation::Ptr> readAll(const std::string& path) {
  RawlogReader r(path);
  std::vector<mrpt::obs::CObservation::Ptr> out;
  while (auto o = r.next()) out.push_back(*o);
  return out;
}

TEST(Convert, TumRgbdFolder) {
  const fs::path d = fresh("rvwo_conv_tum");
  std::ofstream rgb(d / "rgb.txt"), depth(d / "depth.txt"), gt(d / "groundtruth.txt");
  rgb << "# color images\n# file: 'x.bag'\n# timestamp filename\n";
  depth << "# depth maps\n";
  gt << "# ground truth\n";
  for (int i = 0; i < 3; ++i) {
    const std::string t = std::to_string(100 + i * 0.033);
    rgb << t << " rgb/" << i << ".png\n";
    depth << std::to_string(100 + i * 0.033 + 0.005) << " depth/" << i << ".png\n";
    gt << t << " " << i << " 0 0 0 0 0 1\n";
    image(d / "rgb" / (std::to_string(i) + ".png"), 50 * i);
    image(d / "depth" / (std::to_string(i) + ".png"), 5000 + i, CV_16UC1);  // 1 m and a bit
  }
  rgb.close();
  depth.close();
  gt.close();
  const fs::path out = fresh("rvwo_conv_tum_out") / "tum.rawlog";
  ASSERT_EQ(convert("tum --in " + d.string() + " --out " + out.string()), 0);
  const auto obs = readAll(out.string());
  ASSERT_EQ(obs.size(), 3u);
  auto s = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(obs[2]);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->rangeImage(3, 4) * s->rangeUnits, (5000 + 2) / 5000.0, 1e-6);
  s->intensityImage.forceLoad();
  EXPECT_EQ(s->intensityImage.getWidth(), 32u);
  EXPECT_TRUE(fs::exists(out.parent_path() / "groundtruth.txt"));
}

// A TUM folder as the dataset ships it, one frame, under the given folder name.
fs::path tumFolder(const std::string& name) {
  const fs::path d = fresh("rvwo_conv_presets") / name;
  fs::create_directories(d);
  std::ofstream(d / "rgb.txt") << "# color images\n# file: '" << name << ".bag'\n# timestamp filename\n"
                               << "1305031102.175304 rgb/1305031102.175304.png\n";
  std::ofstream(d / "depth.txt") << "# depth maps\n# file: '" << name << ".bag'\n# timestamp filename\n"
                                 << "1305031102.160407 depth/1305031102.160407.png\n";
  image(d / "rgb" / "1305031102.175304.png", 100);
  image(d / "depth" / "1305031102.160407.png", 5000, CV_16UC1);
  return d;
}

// Each Freiburg rig's colour camera as the TUM RGB-D benchmark publishes it ("Intrinsic Camera
// Calibration of the Kinect": fx fy cx cy d0 d1 d2 d3 d4), written as settings.yaml beside the
// rawlog; the rig from the folder's name, or --preset.
TEST(Convert, TumPresetsWriteThePublishedCalibration) {
  const std::map<std::string, std::array<double, 9>> published = {
      {"fr1", {517.3, 516.5, 318.6, 255.3, 0.2624, -0.9531, -0.0054, 0.0026, 1.1633}},
      {"fr2", {520.9, 521.0, 325.1, 249.7, 0.2312, -0.7849, -0.0033, -0.0001, 0.9172}},
      {"fr3", {535.4, 539.2, 320.1, 247.6, 0, 0, 0, 0, 0}}};
  const char* keys[9] = {"Camera1.fx", "Camera1.fy", "Camera1.cx", "Camera1.cy", "Camera1.k1",
                         "Camera1.k2", "Camera1.p1", "Camera1.p2", "Camera1.k3"};
  for (const auto& [rig, values] : published) {
    const fs::path d = tumFolder("rgbd_dataset_freiburg" + rig.substr(2) + "_desk");
    const fs::path out = d.parent_path() / "out" / "sequence.rawlog";
    std::string err;
    ASSERT_EQ(convert("tum --in " + d.string() + " --out " + out.string(), &err), 0) << err;
    cv::FileStorage fs((out.parent_path() / "settings.yaml").string(), cv::FileStorage::READ);
    ASSERT_TRUE(fs.isOpened()) << rig;
    for (int k = 0; k < 9; ++k) EXPECT_DOUBLE_EQ(double(fs[keys[k]]), values[k]) << rig << " " << keys[k];
    EXPECT_EQ(std::string(fs["Sensor"]), "rgbd");
    EXPECT_EQ(double(fs["RGBD.DepthMapFactor"]), 5000.0);
    EXPECT_EQ(int(fs["Camera.width"]), 640);
    EXPECT_EQ(int(fs["Camera.height"]), 480);
    EXPECT_EQ(double(fs["Camera.fps"]), 30.0);
  }
  // --preset on a folder whose name says nothing; a preset that is not there; none at all.
  const fs::path plain = tumFolder("my_copy");
  const fs::path out = plain.parent_path() / "out" / "sequence.rawlog";
  std::string err;
  ASSERT_EQ(convert("tum --preset fr2 --in " + plain.string() + " --out " + out.string(), &err), 0) << err;
  EXPECT_DOUBLE_EQ(
      double(cv::FileStorage((out.parent_path() / "settings.yaml").string(), cv::FileStorage::READ)["Camera1.fx"]),
      520.9);
  fs::remove(out.parent_path() / "settings.yaml");
  EXPECT_EQ(WEXITSTATUS(convert("tum --preset fr4 --in " + plain.string() + " --out " + out.string(), &err)), 1);
  EXPECT_EQ(err, "rvwo-convert: error: --preset fr4: tum has the presets fr1, fr2, fr3\n");
  EXPECT_EQ(WEXITSTATUS(convert("openloris --preset fr3 --in " + plain.string() + " --out " + out.string(), &err)), 1);
  EXPECT_EQ(err, "rvwo-convert: error: --preset fr3: openloris has no presets\n");
  ASSERT_EQ(convert("tum --in " + plain.string() + " --out " + out.string(), &err), 0) << err;
  EXPECT_FALSE(fs::exists(out.parent_path() / "settings.yaml"));
}

TEST(Convert, OpenLorisFolderWithOdometry) {
  const fs::path d = fresh("rvwo_conv_loris");
  std::ofstream color(d / "color.txt"), depth(d / "aligned_depth.txt"), odom(d / "odom.txt"), gt(d / "groundtruth.txt");
  odom << "#Time pose.position.x y z pose.orientation.x y z w twist.linear.x y z twist.angular.x y z\n";
  gt << "#Time px py pz qx qy qz qw\n";
  for (int i = 0; i < 4; ++i) {
    const double t = 1560000000.0 + 0.1 * i;
    color << std::to_string(t) << " color/" << i << ".png\n";
    depth << std::to_string(t + 0.001) << " aligned_depth/" << i << ".png\n";
    image(d / "color" / (std::to_string(i) + ".png"), 100);
    image(d / "aligned_depth" / (std::to_string(i) + ".png"), 1500, CV_16UC1);
    const double yaw = 0.1 * i;
    for (int k = 0; k < 5; ++k) {
      odom << std::to_string(t + 0.02 * k) << " " << 0.05 * (5 * i + k) << " 0 0 0 0 " << std::sin(yaw / 2) << " "
           << std::cos(yaw / 2) << " 0.5 0 0 0 0 0.1\n";
    }
    gt << std::to_string(t) << " " << 0.5 * i << " 0 0 0 0 0 1\n";
  }
  color.close(), depth.close(), odom.close(), gt.close();
  const fs::path out = fresh("rvwo_conv_loris_out") / "loris.rawlog";
  ASSERT_EQ(convert("openloris --in " + d.string() + " --out " + out.string()), 0);
  const auto obs = readAll(out.string());
  ASSERT_EQ(obs.size(), 4u + 20u);
  int scans = 0, odos = 0;
  double last_t = -1;
  for (const auto& o : obs) {
    const double t = mrpt::Clock::toDouble(o->timestamp);
    EXPECT_GE(t, last_t) << "records in time order";
    last_t = t;
    if (auto s = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(o)) {
      ++scans;
      EXPECT_NEAR(s->rangeImage(0, 0) * s->rangeUnits, 1.5, 1e-6);
    }
    if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o)) {
      ++odos;
      if (odos == 6) {
        EXPECT_NEAR(od->odometry.phi(), 0.1, 1e-6);  // the file holds 6 significant digits
      }
    }
  }
  EXPECT_EQ(scans, 4);
  EXPECT_EQ(odos, 20);
  EXPECT_FALSE(fs::exists(out.parent_path() / "settings.yaml")) << "no calibration files, no settings";
}

// An OpenLORIS-Scene sequence ships its calibration beside the data: sensors.yaml (the D435i
// colour camera's intrinsics as [fx, cx, fy, cy], as published for the dataset) and
// trans_matrix.yaml (transforms by parent and child frame). The settings take the camera from the
// one and T_b_c from a chain of the other, walked either way round.
TEST(Convert, OpenLorisSettingsFromTheSequencesOwnCalibration) {
  const fs::path d = fresh("rvwo_conv_loris_calib");
  std::ofstream(d / "color.txt") << "1560000000.0 color/0.png\n";
  std::ofstream(d / "aligned_depth.txt") << "1560000000.001 aligned_depth/0.png\n";
  std::ofstream(d / "odom.txt") << "1560000000.0 0 0 0 0 0 0 1 0 0 0 0 0 0\n";
  image(d / "color" / "0.png", 100);
  image(d / "aligned_depth" / "0.png", 1500, CV_16UC1);
  std::ofstream(d / "sensors.yaml")
      << "%YAML:1.0\nd400_color_optical_frame:\n   sensor_type: camera\n   sensor_name: d400_color_optical_frame\n"
         "   fps: 30\n   width: 848\n   height: 480\n   model: pinhole\n   intrinsics: !!opencv-matrix\n"
         "      rows: 1\n      cols: 4\n      dt: d\n      data: [ 6.1145098876953125e+02, 4.3320397949218750e+02,\n"
         "          6.1148571777343750e+02, 2.4947302246093750e+02 ]\n   distortion_model: radial-tangential\n"
         "   distortion_coefficients: !!opencv-matrix\n      rows: 1\n      cols: 5\n      dt: d\n"
         "      data: [ 0.01, -0.02, 0.001, -0.002, 0.003 ]\n";
  // base_link -> d400_link: 0.2 m ahead, 0.9 m up; the optical frame -> d400_link (the other way round).
  std::ofstream(d / "trans_matrix.yaml")
      << "%YAML:1.0\ntrans_matrix:\n"
         "   - parent_frame: base_link\n     child_frame: d400_link\n     matrix: !!opencv-matrix\n"
         "        rows: 4\n        cols: 4\n        dt: d\n"
         "        data: [ 1, 0, 0, 0.2, 0, 1, 0, 0, 0, 0, 1, 0.9, 0, 0, 0, 1 ]\n"
         "   - parent_frame: d400_color_optical_frame\n     child_frame: d400_link\n     matrix: !!opencv-matrix\n"
         "        rows: 4\n        cols: 4\n        dt: d\n"
         "        data: [ 0, -1, 0, 0.015, 0, 0, -1, 0, 1, 0, 0, 0, 0, 0, 0, 1 ]\n";
  const fs::path out = fresh("rvwo_conv_loris_calib_out") / "loris.rawlog";
  std::string err;
  ASSERT_EQ(convert("openloris --in " + d.string() + " --out " + out.string(), &err), 0) << err;
  cv::FileStorage fs((out.parent_path() / "settings.yaml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  EXPECT_DOUBLE_EQ(double(fs["Camera1.fx"]), 611.4509887695312);
  EXPECT_DOUBLE_EQ(double(fs["Camera1.cx"]), 433.2039794921875);
  EXPECT_DOUBLE_EQ(double(fs["Camera1.fy"]), 611.4857177734375);
  EXPECT_DOUBLE_EQ(double(fs["Camera1.cy"]), 249.4730224609375);
  EXPECT_DOUBLE_EQ(double(fs["Camera1.p2"]), -0.002);
  EXPECT_EQ(int(fs["Camera.width"]), 848);
  EXPECT_EQ(std::string(fs["Sensor"]), "rgbd");
  EXPECT_EQ(double(fs["RGBD.DepthMapFactor"]), 1000.0);
  EXPECT_EQ(std::string(fs["Odometry.Input"]), "pose");
  cv::Mat T;
  fs["Camera.T_b_c"] >> T;
  // T_b_c = T_b_link * inverse(T_c_link): the optical axis (z) ahead along x, x right (-y), y down (-z).
  const cv::Mat expected = (cv::Mat_<double>(4, 4) << 0, 0, 1, 0.2, -1, 0, 0, 0.015, 0, -1, 0, 0.9, 0, 0, 0, 1);
  EXPECT_LT(cv::norm(T - expected, cv::NORM_INF), 1e-12) << T;
  // The T265 pair (--fisheye) from the same two files: Kannala-Brandt k1..k4 (the first four of its
  // coefficients), the right camera in the left's frame, the left on the base.
  std::ofstream(d / "fisheye1.txt") << "1560000000.0 fisheye1/0.png\n";
  std::ofstream(d / "fisheye2.txt") << "1560000000.0 fisheye2/0.png\n";
  image(d / "fisheye1" / "0.png", 90, CV_8UC1);
  image(d / "fisheye2" / "0.png", 90, CV_8UC1);
  std::ofstream(d / "sensors.yaml", std::ios::app)
      << "t265_fisheye1_optical_frame:\n   fps: 30\n   width: 848\n   height: 800\n   intrinsics: !!opencv-matrix\n"
         "      rows: 1\n      cols: 4\n      dt: d\n      data: [ 285.1, 424.6, 285.2, 398.9 ]\n"
         "   distortion_model: equidistant\n   distortion_coefficients: !!opencv-matrix\n      rows: 1\n"
         "      cols: 5\n      dt: d\n      data: [ -0.006, 0.041, -0.039, 0.007, 0. ]\n"
         "t265_fisheye2_optical_frame:\n   fps: 30\n   width: 848\n   height: 800\n   intrinsics: !!opencv-matrix\n"
         "      rows: 1\n      cols: 4\n      dt: d\n      data: [ 284.9, 421.3, 285.0, 400.2 ]\n"
         "   distortion_model: equidistant\n   distortion_coefficients: !!opencv-matrix\n      rows: 1\n"
         "      cols: 5\n      dt: d\n      data: [ -0.005, 0.040, -0.038, 0.006, 0. ]\n";
  std::ofstream(d / "trans_matrix.yaml", std::ios::app)
      << "   - parent_frame: base_link\n     child_frame: t265_fisheye1_optical_frame\n     matrix: !!opencv-matrix\n"
         "        rows: 4\n        cols: 4\n        dt: d\n"
         "        data: [ 0, 0, 1, 0.25, -1, 0, 0, 0.03, 0, -1, 0, 0.8, 0, 0, 0, 1 ]\n"
         "   - parent_frame: t265_fisheye1_optical_frame\n     child_frame: t265_fisheye2_optical_frame\n"
         "     matrix: !!opencv-matrix\n        rows: 4\n        cols: 4\n        dt: d\n"
         "        data: [ 1, 0, 0, 0.064, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 ]\n";
  ASSERT_EQ(convert("openloris --fisheye --in " + d.string() + " --out " + out.string(), &err), 0) << err;
  cv::FileStorage t265((out.parent_path() / "settings.yaml").string(), cv::FileStorage::READ);
  EXPECT_EQ(std::string(t265["Sensor"]), "stereo");
  EXPECT_EQ(std::string(t265["Camera.type"]), "KannalaBrandt8");
  EXPECT_DOUBLE_EQ(double(t265["Camera1.fx"]), 285.1);
  EXPECT_DOUBLE_EQ(double(t265["Camera1.cx"]), 424.6);
  EXPECT_DOUBLE_EQ(double(t265["Camera1.k4"]), 0.007);
  EXPECT_DOUBLE_EQ(double(t265["Camera2.cy"]), 400.2);
  EXPECT_DOUBLE_EQ(double(t265["Camera2.k1"]), -0.005);
  EXPECT_EQ(int(t265["Camera.height"]), 800);
  cv::Mat T12, Tbc;
  t265["Stereo.T_c1_c2"] >> T12;
  t265["Camera.T_b_c"] >> Tbc;
  EXPECT_DOUBLE_EQ(T12.at<double>(0, 3), 0.064);
  EXPECT_DOUBLE_EQ(Tbc.at<double>(2, 3), 0.8);
  // Damaged calibration: one line naming the file, before anything is written.
  std::ofstream(d / "trans_matrix.yaml") << "%YAML:1.0\ntrans_matrix: []\n";
  fs::remove(out.parent_path() / "settings.yaml");
  EXPECT_EQ(WEXITSTATUS(convert("openloris --in " + d.string() + " --out " + out.string(), &err)), 1);
  EXPECT_EQ(err, "rvwo-convert: error: " + (d / "trans_matrix.yaml").string() +
                     ": no chain of transforms from base_link to d400_color_optical_frame\n");
}

TEST(Convert, GenericFolderMonoAndStereo) {
  const fs::path d = fresh("rvwo_conv_generic");
  {
    std::ofstream im(d / "images.txt"), od(d / "odometry.csv");
    od << "t,x,y,theta\n";
    for (int i = 0; i < 3; ++i) {
      im << 10 + i << " cam/" << i << ".png\n";
      image(d / "cam" / (std::to_string(i) + ".png"), 30 * i, CV_8UC1);
      od << 10 + i << "," << i << ",0," << 0.1 * i << "\n";
    }
  }
  const fs::path out = fresh("rvwo_conv_generic_out");
  ASSERT_EQ(convert("generic --in " + d.string() + " --out " + (out / "mono.rawlog").string()), 0);
  auto obs = readAll((out / "mono.rawlog").string());
  ASSERT_EQ(obs.size(), 6u);
  auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs[0]);
  ASSERT_TRUE(im);
  im->image.forceLoad();
  EXPECT_EQ(im->image.getHeight(), 24u);
  {
    std::ofstream r(d / "images_right.txt");
    for (int i = 0; i < 3; ++i) r << 10 + i << " cam/" << i << ".png\n";
  }
  ASSERT_EQ(convert("generic --in " + d.string() + " --out " + (out / "stereo.rawlog").string()), 0);
  obs = readAll((out / "stereo.rawlog").string());
  ASSERT_TRUE(std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(obs[0]));
}

TEST(Convert, MalformedFoldersNameFileAndLine) {
  const fs::path d = fresh("rvwo_conv_bad");
  const std::string out = (fresh("rvwo_conv_bad_out") / "x.rawlog").string();
  std::string err;
  EXPECT_NE(convert("tum --in " + d.string() + " --out " + out, &err), 0);
  EXPECT_EQ(err, "rvwo-convert: error: " + (d / "rgb.txt").string() + ": not found\n");
  image(d / "rgb" / "0.png", 1);
  std::ofstream(d / "rgb.txt") << "1.0 rgb/0.png\n2.0 rgb/1.png\n";
  EXPECT_NE(convert("tum --in " + d.string() + " --out " + out, &err), 0);
  EXPECT_EQ(err, "rvwo-convert: error: " + (d / "rgb.txt").string() + ":2: image 'rgb/1.png' not found\n");
  std::ofstream(d / "rgb.txt") << "1.0 rgb/0.png\nnot-a-time rgb/0.png\n";
  EXPECT_NE(convert("tum --in " + d.string() + " --out " + out, &err), 0);
  EXPECT_NE(err.find("rgb.txt:2: expected 'timestamp path'"), std::string::npos) << err;
  std::ofstream(d / "images.txt") << "1.0 rgb/0.png\n";
  std::ofstream(d / "odometry.csv") << "t,x,y,theta\n1,0,0,0\n2,1,0,0\n1.5,2,0,0\n";
  EXPECT_NE(convert("generic --in " + d.string() + " --out " + out, &err), 0);
  EXPECT_NE(err.find("odometry.csv:4: odometry timestamps must increase"), std::string::npos) << err;
  std::ofstream(d / "odometry.csv") << "t,x,y,theta\n1,0,nan,0\n";
  EXPECT_NE(convert("generic --in " + d.string() + " --out " + out, &err), 0);
  EXPECT_NE(err.find("odometry.csv:2: expected 't,x,y,theta' (numbers)"), std::string::npos) << err;
  // A depth factor that would make every depth zero or negative.
  for (const char* f : {"0", "-1000"}) {
    EXPECT_NE(convert("generic --in " + d.string() + " --depth-factor " + f + " --out " + out, &err), 0) << f;
    EXPECT_EQ(err,
              "rvwo-convert: error: --depth-factor must be > 0 (depth image units per metre: 1000 for "
              "millimetres)\n")
        << f;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_NE(convert("openloris --in " + (d / "missing").string() + " --out " + out, &err), 0);
  EXPECT_EQ(err, "rvwo-convert: error: " + (d / "missing").string() + ": folder not found\n");
}

}  // namespace
}  // namespace rvwo::apps
