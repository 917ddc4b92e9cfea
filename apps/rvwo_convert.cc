// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-convert: turns a dataset folder into an RVWO rawlog (docs/rawlog.md), images referenced in
// place (absolute paths; nothing is copied), depth embedded, odometry as CObservationOdometry, and
// the ground truth copied as TUM groundtruth.txt beside the rawlog.
//
//   tum        a TUM RGB-D folder: rgb.txt, depth.txt (16-bit PNG, 5000 per metre), optional
//              groundtruth.txt; RGB and depth paired by nearest timestamp within --max-dt
//   openloris  an OpenLORIS-Scene folder: color.txt + aligned_depth.txt (RGB-D, 1000 per metre),
//              or with --fisheye, fisheye1.txt + fisheye2.txt (stereo); odom.txt (t, pose, twist);
//              groundtruth.txt
//   generic    images.txt ("t path" per line; optional images_right.txt for stereo, depth.txt for
//              RGB-D with --depth-factor), odometry.csv ("t,x,y,theta" rows; a header line may name
//              other columns: wheel angles left_angle,right_angle or speeds v,omega)
//
// For a public dataset it writes settings.yaml beside the rawlog, the camera as the dataset's
// authors published it (convert/presets.h): a TUM rig's preset (--preset, or the folder's name,
// rgbd_dataset_freiburgN_*), or an OpenLORIS-Scene sequence's own sensors.yaml and
// trans_matrix.yaml; and says what the user must still supply.
//
// Every list line is checked: a malformed line, a missing image, or odometry whose time does not
// increase is one error naming the file and the line.
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>

#include "convert/lists.h"
#include "convert/presets.h"
#include "rvwo/semantics/image_file.h"
#include "support/command_line.h"
#include "support/output.h"
#include "support/rawlog.h"
#include "support/trajectory.h"

namespace fs = std::filesystem;

namespace {

using rvwo::apps::Entry;
using rvwo::apps::fail;
using rvwo::apps::Odometry;
using rvwo::apps::readList;
using rvwo::apps::readOdometryCsv;
using rvwo::apps::readOpenLorisOdometry;

mrpt::obs::CObservation3DRangeScan rgbd(const Entry& rgb, const Entry& depth, double units_per_metre) {
  cv::Mat d;
  try {
    d = rvwo::readImageFile(depth.path, cv::IMREAD_UNCHANGED);
  } catch (const std::runtime_error& e) {
    fail(depth.where, e.what());
  }
  if (d.type() != CV_16UC1) fail(depth.where, "'" + depth.path + "' is not a 16-bit depth image");
  mrpt::obs::CObservation3DRangeScan o;
  o.sensorLabel = "RGBD";
  o.timestamp = mrpt::Clock::fromDouble(rgb.t);
  o.hasIntensityImage = true;
  o.intensityImage.setExternalStorage(rgb.path);
  o.hasRangeImage = true;
  o.range_is_depth = true;
  o.rangeUnits = static_cast<float>(1.0 / units_per_metre);
  o.rangeImage_setSize(d.rows, d.cols);
  // Intrinsics come from the settings; the size must match the images (MRPT checks it on reading).
  o.cameraParams.ncols = o.cameraParamsIntensity.ncols = static_cast<uint32_t>(d.cols);
  o.cameraParams.nrows = o.cameraParamsIntensity.nrows = static_cast<uint32_t>(d.rows);
  for (int r = 0; r < d.rows; ++r) {
    for (int c = 0; c < d.cols; ++c) o.rangeImage(r, c) = d.at<uint16_t>(r, c);
  }
  return o;
}

// Nearest depth entry to t within max_dt, or nullptr.
const Entry* nearest(const std::vector<Entry>& list, double t, double max_dt) {
  auto it = std::lower_bound(list.begin(), list.end(), t, [](const Entry& e, double v) { return e.t < v; });
  const Entry* best = nullptr;
  if (it != list.end()) best = &*it;
  if (it != list.begin() && (!best || t - std::prev(it)->t < best->t - t)) best = &*std::prev(it);
  return best && std::fabs(best->t - t) <= max_dt ? best : nullptr;
}

// The command line, in the order --help lists it.
struct ConvertArgs {
  TCLAP::CmdLine cmd{
      "rvwo-convert: a TUM RGB-D, OpenLORIS-Scene or generic (images + odometry CSV) folder to an RVWO rawlog; "
      "images are referenced in place, the ground truth copied beside the rawlog.",
      ' ', RVWO_VERSION};
  std::vector<std::string> kinds = {"tum", "openloris", "generic"};
  TCLAP::ValuesConstraint<std::string> kinds_c{kinds};
  TCLAP::UnlabeledValueArg<std::string> kind{"kind", "the folder's format", true, "", &kinds_c, cmd};
  TCLAP::ValueArg<std::string> in{"", "in", "the dataset folder", true, "", "DIR", cmd};
  TCLAP::ValueArg<std::string> out{"", "out", "the rawlog to write", true, "", "R.rawlog", cmd};
  TCLAP::ValueArg<double> max_dt{"",  "max-dt", "largest image/depth timestamp gap paired, s (0.02)", false, 0.02,
                                 "s", cmd};
  TCLAP::SwitchArg fisheye{"", "fisheye", "openloris: the T265 fisheye pair instead of RGB-D", cmd};
  TCLAP::ValueArg<double> depth_factor{"", "depth-factor", "generic: depth units per metre (1000)", false, 1000, "f",
                                       cmd};
  TCLAP::ValueArg<std::string> preset{
      "",
      "preset",
      "the dataset's published camera, written as settings.yaml beside the rawlog: tum fr1|fr2|fr3 (default: from a "
      "TUM folder's name, rgbd_dataset_freiburgN_...); generic: the same, for frames from a TUM bag (rvwo-bag)",
      false,
      "",
      "name",
      cmd};
};

// A dataset's records, gathered in time order, then written as one rawlog.
class Conversion {
 public:
  explicit Conversion(double max_dt) : max_dt_(max_dt) {}

  void addRgbd(const std::vector<Entry>& rgb, const std::vector<Entry>& depth, double units) {
    for (const Entry& e : rgb) {
      const Entry* d = nearest(depth, e.t, max_dt_);
      if (!d) continue;  // unpaired frames are skipped, as TUM's associate.py does
      records_.emplace(e.t, [e, d = *d, units](rvwo::apps::RawlogWriter& w) { w.write(rgbd(e, d, units)); });
      ++frames_;
    }
    if (frames_ == 0) throw std::runtime_error("no image pairs with depth within --max-dt");
  }
  void addMono(const std::vector<Entry>& left) {
    for (const Entry& e : left) {
      records_.emplace(e.t, [e](rvwo::apps::RawlogWriter& w) {
        mrpt::obs::CObservationImage o;
        o.sensorLabel = "CAMERA";
        o.timestamp = mrpt::Clock::fromDouble(e.t);
        o.image.setExternalStorage(e.path);
        w.write(o);
      });
      ++frames_;
    }
  }
  void addStereo(const std::vector<Entry>& left, const std::vector<Entry>& right) {
    for (const Entry& e : left) {
      const Entry* r = nearest(right, e.t, max_dt_);
      if (!r) continue;
      records_.emplace(e.t, [e, r = *r](rvwo::apps::RawlogWriter& w) {
        mrpt::obs::CObservationStereoImages o;
        o.sensorLabel = "CAMERA";
        o.timestamp = mrpt::Clock::fromDouble(e.t);
        o.imageLeft.setExternalStorage(e.path);
        o.imageRight.setExternalStorage(r.path);
        o.hasImageRight = true;
        w.write(o);
      });
      ++frames_;
    }
  }
  void addOdometry(const std::vector<Odometry>& odo) {
    for (const Odometry& o : odo) {
      records_.emplace(o.t, [o](rvwo::apps::RawlogWriter& w) {
        mrpt::obs::CObservationOdometry obs;
        obs.sensorLabel = "ODOMETRY";
        obs.timestamp = mrpt::Clock::fromDouble(o.t);
        obs.odometry = mrpt::poses::CPose2D(o.x, o.y, o.theta);
        obs.hasEncodersInfo = o.angles;
        obs.encoderLeftTicks = o.ticks_left;
        obs.encoderRightTicks = o.ticks_right;
        obs.hasVelocities = o.twist;
        obs.velocityLocal = mrpt::math::TTwist2D(o.v, 0, o.omega);
        w.write(obs);
      });
      ++odometry_;
    }
  }
  // The folder's groundtruth.txt, if it has one, goes beside the rawlog.
  void groundTruthFrom(const fs::path& folder) {
    if (fs::exists(folder / "groundtruth.txt")) ground_truth_ = (folder / "groundtruth.txt").string();
  }

  void write(const std::string& out, const fs::path& in) const {
    fs::create_directories(fs::absolute(out).parent_path());
    rvwo::apps::RawlogWriter writer(out);
    for (auto& [t, write] : records_) write(writer);
    if (!ground_truth_.empty()) {
      // Checked and rewritten in full precision (TUM files repeat a timestamp now and then: skipped).
      rvwo::apps::writeTum((fs::absolute(out).parent_path() / "groundtruth.txt").string(),
                           rvwo::apps::readTum(ground_truth_, 0, /*lenient=*/true));
    }
    std::printf("rvwo-convert: %s: %zu frames, %zu odometry readings -> %s%s\n", in.string().c_str(), frames_,
                odometry_, out.c_str(), ground_truth_.empty() ? "" : " (+ groundtruth.txt)");
  }

 private:
  double max_dt_;
  std::multimap<double, std::function<void(rvwo::apps::RawlogWriter&)>> records_;  // written in time order
  std::size_t frames_ = 0, odometry_ = 0;
  std::string ground_truth_;
};

// TUM RGB-D: rgb.txt, depth.txt (5000 units a metre), groundtruth.txt; no odometry.
void readTumFolder(const fs::path& in, Conversion* c) {
  const auto rgb = readList(in, "rgb.txt");  // in this order: errors name the first list first
  const auto depth = readList(in, "depth.txt");
  c->addRgbd(rgb, depth, 5000.0);
  c->groundTruthFrom(in);
}

// OpenLORIS-Scene: color.txt and aligned_depth.txt (mm), or the fisheye pair; odom.txt.
void readOpenLorisFolder(const fs::path& in, bool fisheye, Conversion* c) {
  if (fisheye) {
    const auto left = readList(in, "fisheye1.txt");
    const auto right = readList(in, "fisheye2.txt");
    c->addStereo(left, right);
  } else {
    const auto color = readList(in, "color.txt");
    const auto depth = readList(in, "aligned_depth.txt");
    c->addRgbd(color, depth, 1000.0);
  }
  c->addOdometry(readOpenLorisOdometry(in / "odom.txt"));
  c->groundTruthFrom(in);
}

// Generic: images.txt, and images_right.txt (stereo) or depth.txt (RGB-D); odometry.csv if any.
void readGenericFolder(const fs::path& in, double depth_factor, Conversion* c) {
  const auto left = readList(in, "images.txt");
  const auto right = readList(in, "images_right.txt", false);
  const auto depth = readList(in, "depth.txt", false);
  if (!right.empty()) {
    c->addStereo(left, right);
  } else if (!depth.empty()) {
    c->addRgbd(left, depth, depth_factor);
  } else {
    c->addMono(left);
  }
  if (fs::exists(in / "odometry.csv")) c->addOdometry(readOdometryCsv(in / "odometry.csv"));  // else vision only
  c->groundTruthFrom(in);
}

// The preset asked for, the one a TUM folder's name gives, or an OpenLORIS-Scene sequence's own
// calibration files; none: nullopt.
std::optional<rvwo::apps::DatasetPreset> presetOf(ConvertArgs& args, const fs::path& in) {
  const std::string& kind = args.kind.getValue();
  if (args.preset.isSet() && kind == "generic") {  // a TUM rig's frames, in --depth-factor units (rvwo-bag's mm)
    rvwo::apps::DatasetPreset p = rvwo::apps::datasetPreset("tum", args.preset.getValue());
    p.depth_factor = args.depth_factor.getValue();
    return p;
  }
  if (args.preset.isSet()) return rvwo::apps::datasetPreset(kind, args.preset.getValue());
  if (kind == "tum") {
    const std::string rig = rvwo::apps::tumPresetOfFolder(in);
    if (!rig.empty()) return rvwo::apps::datasetPreset(kind, rig);
  }
  if (kind == "openloris" && fs::exists(in / "sensors.yaml"))
    return rvwo::apps::openLorisCalibration(in, args.fisheye.getValue());
  return std::nullopt;
}

// Why no settings were written, and what to do.
std::string noSettingsReason(ConvertArgs& args) {
  if (args.kind.getValue() == "tum") return "give --preset fr1, fr2 or fr3 (the folder's name names no Freiburg rig)";
  if (args.kind.getValue() == "openloris")
    return "the folder has no sensors.yaml and trans_matrix.yaml: copy them in from the sequence's download";
  return "write them for your camera (docs/rawlog.md)";
}

int convert(ConvertArgs& args) {
  const fs::path in(args.in.getValue());
  if (!(args.depth_factor.getValue() > 0) || !std::isfinite(args.depth_factor.getValue()))
    throw std::invalid_argument("--depth-factor must be > 0 (depth image units per metre: 1000 for millimetres)");
  if (!fs::is_directory(in)) throw std::runtime_error(in.string() + ": folder not found");
  const auto preset = presetOf(args, in);
  const fs::path settings = fs::absolute(args.out.getValue()).parent_path() / "settings.yaml";
  Conversion c(args.max_dt.getValue());
  if (args.kind.getValue() == "tum") {
    readTumFolder(in, &c);
  } else if (args.kind.getValue() == "openloris") {
    readOpenLorisFolder(in, args.fisheye.getValue(), &c);
  } else {
    readGenericFolder(in, args.depth_factor.getValue(), &c);
  }
  c.write(args.out.getValue(), in);
  if (preset) {
    rvwo::apps::writePresetSettings(*preset, settings);
    std::printf("rvwo-convert: %s: %s, from %s\n", settings.string().c_str(), preset->title.c_str(),
                preset->kind == "openloris" ? preset->source.c_str() : ("preset " + preset->name).c_str());
    if (!preset->still_to_supply.empty())
      std::printf("rvwo-convert: still to supply: %s\n", preset->still_to_supply.c_str());
  } else {
    std::printf("rvwo-convert: no settings written: %s\n", noSettingsReason(args).c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-convert", [&] {
    ConvertArgs args;
    if (const auto status = rvwo::apps::parseCommandLine(args.cmd, argc, argv)) return *status;
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
    return convert(args);
  });
}
