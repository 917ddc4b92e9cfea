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

#include "convert/presets.h"
#include "support/command_line.h"
#include "support/output.h"
#include "support/rawlog.h"
#include "support/trajectory.h"

namespace fs = std::filesystem;

namespace {

struct Entry {
  double t;
  std::string path;   // absolute
  std::string where;  // "file:line", for messages
};

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

std::vector<std::string> splitFields(std::string line) {
  for (char& c : line) {
    if (c == ',' || c == '\t') c = ' ';
  }
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string f; in >> f;) out.push_back(f);
  return out;
}

bool number(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && *end == '\0' && std::isfinite(*v);
}

// "t path" lists (TUM rgb.txt, OpenLORIS color.txt, ...): '#' comments; paths relative to the folder.
std::vector<Entry> readList(const fs::path& folder, const std::string& name, bool required = true) {
  const fs::path file = folder / name;
  std::ifstream in(file);
  if (!in) {
    if (required) fail(file.string(), "not found");
    return {};
  }
  std::vector<Entry> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string where = file.string() + ":" + std::to_string(n);
    const auto f = splitFields(line);
    if (f.empty() || f[0][0] == '#') continue;
    double t;
    if (f.size() < 2 || !number(f[0], &t)) fail(where, "expected 'timestamp path'");
    const fs::path p = folder / f[1];
    if (!fs::is_regular_file(p)) fail(where, "image '" + f[1] + "' not found");
    if (!out.empty() && !(t > out.back().t)) fail(where, "timestamps must increase");
    out.push_back({t, fs::absolute(p).string(), where});
  }
  if (out.empty()) fail(file.string(), "no entries");
  return out;
}

struct Odometry {
  double t = 0, x = 0, y = 0, theta = 0;  // s; the odometry's pose, m and rad
  bool pose = true, angles = false, twist = false;
  std::int32_t ticks_left = 0, ticks_right = 0;  // wheel angles as encoder ticks, kTicksPerRevolution a turn
  double v = 0, omega = 0;                       // forward speed (m/s) and turn rate (rad/s)
};

// Encoder ticks a wheel turn, for wheel angles given in radians (rvwo-bag writes the same into the
// settings as Odometry.TicksPerRevolution): a power of two, so that ticks scale angles exactly.
constexpr double kTicksPerRevolution = 65536;

// odom.txt (OpenLORIS: t x y z qx qy qz qw [twist]).
std::vector<Odometry> readOpenLorisOdometry(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(file.string(), "not found");
  std::vector<Odometry> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string where = file.string() + ":" + std::to_string(n);
    const auto f = splitFields(line);
    if (f.empty() || f[0][0] == '#') continue;
    double v[8];
    bool ok = f.size() >= 8;
    for (std::size_t i = 0; ok && i < 8; ++i) ok = number(f[i], &v[i]);
    if (!ok) fail(where, "expected 't x y z qx qy qz qw ...'");
    Odometry o;
    o.t = v[0];
    o.x = v[1];
    o.y = v[2];
    o.theta = 2 * std::atan2(v[6], v[7]);  // yaw of a planar pose (qx, qy ~ 0)
    if (!out.empty() && !(o.t > out.back().t)) fail(where, "odometry timestamps must increase");
    out.push_back(o);
  }
  if (out.empty()) fail(file.string(), "no odometry");
  return out;
}

// odometry.csv's columns: a header line naming them, each among these, in any order; without one
// (or with a header of other names), t, x, y, theta.
const std::vector<std::string> kOdometryColumns = {"t", "x", "y", "theta", "left_angle", "right_angle", "v", "omega"};

std::vector<int> namedColumns(const std::vector<std::string>& header, const std::string& where) {
  std::vector<int> col;
  for (const std::string& h : header) {
    const auto it = std::find(kOdometryColumns.begin(), kOdometryColumns.end(), h);
    if (it == kOdometryColumns.end()) return {0, 1, 2, 3};  // another header: the old layout
    col.push_back(static_cast<int>(it - kOdometryColumns.begin()));
  }
  auto has = [&](int c) { return std::find(col.begin(), col.end(), c) != col.end(); };
  const bool pose = has(1) && has(2) && has(3), angles = has(4) && has(5), twist = has(6) && has(7);
  if (!has(0) || (has(1) || has(2) || has(3)) != pose || has(4) != angles || has(5) != angles || has(6) != twist ||
      has(7) != twist || !(pose || angles || twist))
    fail(where, "columns: t, and x,y,theta (pose) and/or left_angle,right_angle (rad) and/or v,omega (m/s, rad/s)");
  return col;
}

// odometry.csv: the odometry's pose, wheel angles or speeds, by its header (kOdometryColumns).
std::vector<Odometry> readOdometryCsv(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(file.string(), "not found");
  std::vector<Odometry> out;
  std::vector<int> col = {0, 1, 2, 3};
  bool header = false;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string where = file.string() + ":" + std::to_string(n);
    const auto f = splitFields(line);
    if (f.empty() || f[0][0] == '#') continue;
    double v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    if (!header && out.empty() && !number(f[0], &v[0])) {
      header = true;
      col = namedColumns(f, where);
      continue;
    }
    bool ok = f.size() >= col.size();
    for (std::size_t i = 0; ok && i < col.size(); ++i) ok = number(f[i], &v[col[i]]);
    if (!ok) {
      std::string names;
      for (int c : col) names += (names.empty() ? "" : ",") + kOdometryColumns[c];
      fail(where, "expected '" + names + "' (numbers)");
    }
    Odometry o;
    o.t = v[0];
    o.x = v[1];
    o.y = v[2];
    o.theta = v[3];
    o.pose = std::find(col.begin(), col.end(), 1) != col.end();
    o.angles = std::find(col.begin(), col.end(), 4) != col.end();
    o.twist = std::find(col.begin(), col.end(), 6) != col.end();
    if (o.angles) {
      const double k = kTicksPerRevolution / (2 * M_PI), l = std::round(v[4] * k), r = std::round(v[5] * k);
      if (std::fabs(l) > INT32_MAX || std::fabs(r) > INT32_MAX)
        fail(where, "a wheel angle beyond what 32-bit encoder ticks hold (" + std::to_string(INT32_MAX / k) + " rad)");
      o.ticks_left = static_cast<std::int32_t>(l);
      o.ticks_right = static_cast<std::int32_t>(r);
    }
    o.v = v[6];
    o.omega = v[7];
    if (!out.empty() && !(o.t > out.back().t)) fail(where, "odometry timestamps must increase");
    out.push_back(o);
  }
  if (out.empty()) fail(file.string(), "no odometry");
  return out;
}

mrpt::obs::CObservation3DRangeScan rgbd(const Entry& rgb, const Entry& depth, double units_per_metre) {
  const cv::Mat d = cv::imread(depth.path, cv::IMREAD_UNCHANGED);
  if (d.empty() || d.type() != CV_16UC1) fail(depth.where, "'" + depth.path + "' is not a 16-bit depth image");
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
      "TUM folder's name, rgbd_dataset_freiburgN_...)",
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
// calibration files (RGB-D); none: nullopt.
std::optional<rvwo::apps::DatasetPreset> presetOf(ConvertArgs& args, const fs::path& in) {
  const std::string& kind = args.kind.getValue();
  if (args.preset.isSet()) return rvwo::apps::datasetPreset(kind, args.preset.getValue());
  if (kind == "tum" && !rvwo::apps::tumPresetOfFolder(in).empty())
    return rvwo::apps::datasetPreset(kind, rvwo::apps::tumPresetOfFolder(in));
  if (kind == "openloris" && !args.fisheye.getValue() && fs::exists(in / "sensors.yaml"))
    return rvwo::apps::openLorisCalibration(in);
  return std::nullopt;
}

// Why no settings were written, and what to do.
std::string noSettingsReason(ConvertArgs& args) {
  if (args.kind.getValue() == "tum") return "give --preset fr1, fr2 or fr3 (the folder's name names no Freiburg rig)";
  if (args.kind.getValue() == "openloris")
    return args.fisheye.getValue() ? "the T265 pair's calibration is not read yet: write them from the sequence's "
                                     "sensors.yaml (docs/datasets.md)"
                                   : "the folder has no sensors.yaml and trans_matrix.yaml: copy them in from the "
                                     "sequence's download";
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
