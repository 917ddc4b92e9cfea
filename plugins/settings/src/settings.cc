// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/settings/settings.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <opencv2/core.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

namespace rvwo {

struct Settings::Impl {
  cv::FileStorage fs;
};

Settings::Settings() : impl_(std::make_unique<Impl>()) {}
Settings::~Settings() = default;
Settings::Settings(Settings&&) noexcept = default;
Settings& Settings::operator=(Settings&&) noexcept = default;

namespace {

// OpenCV's YAML parse error as "line N: what" (its message reads "... in function
// '<name>(N): what'"); its bare text when it has no line.
std::string parseError(const cv::Exception& e) {
  const std::string& m = e.msg;
  const std::size_t open = m.rfind("): "), paren = open == std::string::npos ? open : m.rfind('(', open);
  if (paren == std::string::npos) return e.err;
  std::string what = m.substr(open + 3);
  while (!what.empty() && what.back() == '\n') what.pop_back();
  if (!what.empty() && what.back() == '\'') what.pop_back();  // the quote that closes "in function '...'"
  return "line " + m.substr(paren + 1, open - paren - 1) + ": " + what;
}

// A top-level key given twice is an error naming both lines (the reader would take one silently).
void checkDuplicateKeys(const std::string& name, const std::string& text) {
  std::map<std::string, int> first_line;
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || std::isspace(static_cast<unsigned char>(line[0])) || line[0] == '#' || line[0] == '%' ||
        line[0] == '-')
      continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    while (!key.empty() && std::isspace(static_cast<unsigned char>(key.back()))) key.pop_back();
    if (key.size() > 1 && (key.front() == '"' || key.front() == '\'')) key = key.substr(1, key.size() - 2);
    const auto [it, fresh] = first_line.emplace(key, n);
    if (!fresh)
      throw std::runtime_error(name + ": " + key + " is given twice (lines " + std::to_string(it->second) + " and " +
                               std::to_string(n) + "): keep one");
  }
}

// One document, its keys from the first column. OpenCV 4.6's YAML parser loops for ever when its
// top-level map ends before the text does and a '-' comes next; fuzzing found three ways in: the
// first key indented, keys on the '---' line (an indented map), text after a '...' line (the
// document's end). Each is refused before OpenCV reads the file.
void checkOneDocument(const std::string& name, const std::string& text) {
  std::istringstream in(text);
  std::string line;
  bool keys = false, ended = false;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::size_t at = line.find_first_not_of(" \t\r");
    if (at == std::string::npos || line[at] == '#') continue;
    const auto refuse = [&](const std::string& why) {
      throw std::runtime_error(name + ": line " + std::to_string(n) + ": " + why);
    };
    if (ended) refuse("text after the document's end ('...'): a settings file is one document");
    if (at == 0 && line.compare(0, 3, "...") == 0) {
      ended = true;
    } else if (line.compare(at, 3, "---") == 0) {
      const std::size_t next = line.find_first_not_of(" \t\r", at + 3);
      if (next != std::string::npos && line[next] != '#')
        refuse("text after '---' on its line (start the keys on the next line)");
    } else if (!keys && line[at] != '%') {
      if (at > 0) refuse("the first key is indented (top-level keys start in the first column)");
      keys = true;
    }
  }
}

}  // namespace

void checkYamlText(const std::string& name, const std::string& text) {
  int line = 1;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 && c != '\t' && c != '\n' && c != '\r') {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", u);
      throw std::runtime_error(name + ": line " + std::to_string(line) + ": a control character (byte " + hex +
                               "): a settings file is text (a damaged copy?)");
    }
    line += c == '\n';
  }
  checkOneDocument(name, text);
}

Settings Settings::load(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error(path + ": settings file not found");
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw std::runtime_error(path + ": cannot be read");
  if (text.str().rfind("%YAML", 0) != 0)
    throw std::runtime_error(path + ": not a settings YAML file (its first line must be %YAML:1.0)");
  checkYamlText(path, text.str());
  Settings s;
  s.path_ = path;
  try {
    if (!s.impl_->fs.open(path, cv::FileStorage::READ)) throw std::runtime_error("cannot open");
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": " + parseError(e));
  } catch (const std::runtime_error&) {
    throw std::runtime_error(path + ": cannot be read as a settings YAML file");
  }
  checkDuplicateKeys(path, text.str());
  return s;
}

Settings Settings::fromString(const std::string& yaml, const std::string& name) {
  checkYamlText(name, yaml);
  Settings s;
  s.path_ = name;
  try {
    s.impl_->fs.open(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(name + ": not a settings YAML text: " + parseError(e));
  }
  checkDuplicateKeys(name, yaml);
  return s;
}

bool Settings::has(const std::string& key) const { return !impl_->fs[key].empty() && !impl_->fs[key].isNone(); }

std::optional<double> Settings::number(const std::string& key) const {
  const cv::FileNode n = impl_->fs[key];
  if (n.empty() || n.isNone()) return std::nullopt;
  if (!n.isReal() && !n.isInt()) throw std::invalid_argument(path_ + ": " + key + " must be a number");
  return static_cast<double>(n);
}

std::optional<std::string> Settings::text(const std::string& key) const {
  const cv::FileNode n = impl_->fs[key];
  if (n.empty() || n.isNone()) return std::nullopt;
  if (!n.isString()) throw std::invalid_argument(path_ + ": " + key + " must be a string");
  return static_cast<std::string>(n);
}

std::optional<std::string> Settings::file(const std::string& key) const {
  const auto t = text(key);
  if (!t) return std::nullopt;
  return std::filesystem::absolute(std::filesystem::path(path_).parent_path() / *t).string();  // / keeps an absolute *t
}

double Settings::requireNumber(const std::string& key) const {
  const auto v = number(key);
  if (!v) throw std::invalid_argument(path_ + ": missing key " + key);
  return *v;
}

std::optional<std::vector<double>> Settings::matrix(const std::string& key, int rows, int cols) const {
  const cv::FileNode n = impl_->fs[key];
  if (n.empty() || n.isNone()) return std::nullopt;
  const std::string wrong =
      path_ + ": " + key + " must be a " + std::to_string(rows) + "x" + std::to_string(cols) + " !!opencv-matrix";
  // The shape is checked before OpenCV reads the matrix: it allocates rows x cols as the file says.
  if (!n.isMap() || !n["rows"].isInt() || !n["cols"].isInt() || static_cast<int>(n["rows"]) != rows ||
      static_cast<int>(n["cols"]) != cols)
    throw std::invalid_argument(wrong);
  cv::Mat m;
  try {
    n >> m;
  } catch (const cv::Exception&) {
    m.release();
  }
  if (m.empty() || m.rows != rows || m.cols != cols || m.channels() != 1) throw std::invalid_argument(wrong);
  m.convertTo(m, CV_64F);
  std::vector<double> out(m.begin<double>(), m.end<double>());
  for (double v : out) {
    if (!std::isfinite(v)) throw std::invalid_argument(path_ + ": " + key + " has a value that is not finite");
  }
  return out;
}

std::vector<std::string> Settings::keysWithPrefix(const std::string& prefix) const {
  std::vector<std::string> out;
  for (const std::string& k : impl_->fs.root().keys()) {
    if (k.rfind(prefix, 0) == 0) out.push_back(k);
  }
  return out;
}

ReliabilityParams readReliability(const Settings& s, ReliabilityParams p) {
  for (const std::string& key : ReliabilityParams::keys()) {
    if (const auto v = s.number(key)) p.set(key, *v);
  }
  for (const std::string& key : s.keysWithPrefix("Reliability.")) {
    if (!p.get(key)) throw std::invalid_argument(s.path() + ": unknown key " + key);
  }
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.path() + ": " + e.what());
  }
  return p;
}

WheelNoise readWheelNoise(const Settings& s, WheelNoise n) {
  const std::pair<const char*, double WheelNoise::*> keys[] = {
      {"Odometry.NoiseX", &WheelNoise::sigma_x},         {"Odometry.NoiseY", &WheelNoise::sigma_y},
      {"Odometry.NoiseRot", &WheelNoise::sigma_phi},     {"Odometry.NoiseRotPerMetre", &WheelNoise::sigma_phi_s},
      {"Odometry.NoiseWheel", &WheelNoise::sigma_wheel}, {"Odometry.NoiseFloorP", &WheelNoise::floor_p},
      {"Odometry.NoiseFloorRot", &WheelNoise::floor_phi}};
  for (const auto& [key, member] : keys) {
    if (const auto v = s.number(key)) n.*member = *v;
  }
  try {
    n.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.path() + ": " + e.what());
  }
  return n;
}

Eigen::Isometry3d readIsometry(const Settings& s, const std::string& key, bool required) {
  const auto m = s.matrix(key, 4, 4);
  if (!m) {
    if (required) throw std::invalid_argument(s.path() + ": missing key " + key);
    return Eigen::Isometry3d::Identity();
  }
  Eigen::Matrix4d M = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(m->data());
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || std::fabs(R.determinant() - 1) > 1e-6 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
    throw std::invalid_argument(s.path() + ": " + key + " is not a rigid transform (rotation and translation)");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

DiffDriveParams readDiffDrive(const Settings& s, DiffDriveParams d) {
  if (const auto v = s.number("Odometry.WheelRadiusLeft")) d.radius_left = *v;
  if (const auto v = s.number("Odometry.WheelRadiusRight")) d.radius_right = *v;
  if (const auto v = s.number("Odometry.Track")) d.track = *v;
  try {
    d.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.path() + ": " + e.what());
  }
  return d;
}

std::optional<double> renamedNumber(const Settings& s, const std::string& key, const std::string& old_key,
                                    std::ostream* warnings) {
  const std::optional<double> v = s.number(key);
  if (old_key.empty() || !s.has(old_key)) return v;
  if (v)
    throw std::invalid_argument(s.path() + ": " + key + " and its old name " + old_key + " are both given; keep " +
                                key);
  static std::mutex mutex;
  static std::set<std::string> warned;
  std::lock_guard<std::mutex> lock(mutex);
  if (warned.insert(s.path() + "\n" + old_key).second)
    (warnings ? *warnings : std::cerr) << s.path() << ": " << old_key << " is now " << key
                                       << " (read under its old name for now; rename it)\n";
  return s.number(old_key);
}

TrackingOptions readTrackingOptions(const Settings& s, TrackingOptions o, std::ostream* warnings) {
  // Each key with the name the estimator read it by before ("": none).
  const auto whole = [&](const char* key, const char* old_key, int* member) {
    if (const auto v = renamedNumber(s, key, old_key, warnings)) {
      if (!(*v == std::floor(*v) && std::fabs(*v) < 1e9))
        throw std::invalid_argument(s.path() + ": " + key + " must be a whole number");
      *member = static_cast<int>(*v);
    }
  };
  const auto real = [&](const char* key, const char* old_key, double* member) {
    if (const auto v = renamedNumber(s, key, old_key, warnings)) *member = *v;
  };
  const auto flag = [&](const char* key, const char* old_key, bool* member) {
    if (const auto v = renamedNumber(s, key, old_key, warnings)) *member = *v != 0;
  };
  whole("Tracking.MinInliers", "Estimator.MinInliers", &o.min_inliers);
  real("Tracking.SlipMinInliers", "Estimator.SlipMinInliers", &o.slip_min_inliers);
  real("Tracking.SlipHold", "Estimator.SlipHold", &o.slip_hold);
  whole("Tracking.SlipHoldMinFrames", "Estimator.SlipHoldMinFrames", &o.slip_hold_min_frames);
  real("Tracking.TrustedMaxPs", "Estimator.TrustedMaxPs", &o.trusted_max_ps);
  flag("Tracking.SlipCheck", "", &o.slip_check);
  flag("Tracking.WheelGate", "Estimator.WheelGate", &o.wheel_gate);
  real("Tracking.BarronScale", "Estimator.BarronScale", &o.barron_scale);
  real("Tracking.SigmaZ", "Estimator.SigmaZ", &o.sigma_z);
  real("Tracking.SigmaRollPitch", "Estimator.SigmaRollPitch", &o.sigma_rollpitch);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.path() + ": " + e.what());
  }
  return o;
}

void writeTrackingOptions(std::ostream& out, const TrackingOptions& o) {
  const auto precision = out.precision(17);
  out << "Tracking.MinInliers: " << o.min_inliers << "\nTracking.SlipMinInliers: " << o.slip_min_inliers
      << "\nTracking.SlipHold: " << o.slip_hold << "\nTracking.SlipHoldMinFrames: " << o.slip_hold_min_frames
      << "\nTracking.TrustedMaxPs: " << o.trusted_max_ps << "\nTracking.SlipCheck: " << (o.slip_check ? 1 : 0)
      << "\nTracking.WheelGate: " << (o.wheel_gate ? 1 : 0) << "\nTracking.BarronScale: " << o.barron_scale
      << "\nTracking.SigmaZ: " << o.sigma_z << "\nTracking.SigmaRollPitch: " << o.sigma_rollpitch << "\n";
  out.precision(precision);
}

int readLabelDilation(const Settings& s, int defaults, const std::string& old_key) {
  const std::optional<double> v = renamedNumber(s, "Segmentation.LabelDilation", old_key);
  if (!v) return defaults;
  if (!(*v == std::floor(*v) && *v >= 0 && *v <= 100))
    throw std::invalid_argument(s.path() + ": Segmentation.LabelDilation must be a whole number of pixels, 0 to 100");
  return static_cast<int>(*v);
}

SemanticPriors readSemanticPriors(const Settings& s) {
  const std::string set = s.text("Semantics.LabelSet").value_or("voc21");
  SemanticPriors priors = [&] {
    try {
      return SemanticPriors::builtin(set);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(s.path() + ": Semantics.LabelSet: " + e.what());
    }
  }();
  if (const auto file = s.file("Semantics.PriorsFile")) {
    const std::filesystem::path p(*file);
    std::ifstream in(p);
    if (!in) throw std::invalid_argument(s.path() + ": Semantics.PriorsFile '" + p.string() + "' cannot be read");
    priors.overrideFrom(in, p.string());
  }
  const std::string prefix = "Semantics.Prior.";
  for (const std::string& key : s.keysWithPrefix(prefix)) {
    try {
      priors.set(key.substr(prefix.size()), *s.number(key));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(s.path() + ": " + key + ": " + e.what());
    }
  }
  return priors;
}

}  // namespace rvwo
